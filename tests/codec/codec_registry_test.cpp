// The codec table (volcast/codec/registry.hpp): every registered codec keeps what its entry
// promises - lossless ones are bit-exact on real frames, near-lossless ones stay within their
// bound on every pixel, temporal ones refuse a delta frame without its key frame - and the
// lookups, errors and help text say what is in the table. The video codecs are registered as
// the volcast CLI does (register_video_codecs()).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>

#include "support/test_data.hpp"
#include "volcast/codec/registry.hpp"
#include "volcast/codec/tier.hpp"
#include "volcast/codec_video/video_codecs.hpp"
#include "volcast/core/error.hpp"

namespace volcast {
namespace {

class CodecRegistry : public ::testing::Test {
 protected:
  void SetUp() override { register_video_codecs(); }
};

// Real frames of every shared set: the Kinect frame, consecutive hands frames (so temporal
// codecs code real deltas), the four-camera and the binned frames.
std::vector<std::pair<std::string, std::vector<DepthImage>>> real_sequences() {
  auto hands = test::real_depth_frames("hands", 12);
  return {{"kinect", test::real_depth_frames("kinect")},
          {"hands", hands},
          {"4cam", test::real_depth_frames("4cam")},
          {"binned", test::real_depth_frames("binned")}};
}

std::string join(const std::vector<std::string>& names) {
  std::string s;
  for (const std::string& n : names) s += (s.empty() ? "" : ", ") + n;
  return s;
}

TEST_F(CodecRegistry, EveryRegisteredNameMakesAnEncoderAndADecoder) {
  const std::vector<DepthCodecInfo> depth = all_depth_codecs();
  std::vector<std::string> names;
  for (const DepthCodecInfo& c : depth) {
    names.emplace_back(c.name);
    EXPECT_EQ(make_depth_encoder(c.name)->name(), c.name);
    EXPECT_NE(make_depth_decoder(c.name), nullptr) << c.name;
    EXPECT_EQ(find_depth_codec(c.name), &depth_codec_info(c.name)) << c.name;
    EXPECT_FALSE(c.summary.empty()) << c.name;
  }
  EXPECT_EQ(names, depth_codec_names());
  EXPECT_EQ(join(names),
            "raw, rvl, trvl, zstd, lz4, volcast, volcast-t, volcast-n1, volcast-n2, volcast-n4, "
            "h264, hevc");

  names.clear();
  for (const ColorCodecInfo& c : all_color_codecs()) {
    names.emplace_back(c.name);
    EXPECT_EQ(make_color_encoder(c.name)->name(), c.name);
    EXPECT_NE(make_color_decoder(c.name), nullptr) << c.name;
    EXPECT_EQ(find_color_codec(c.name), &color_codec_info(c.name)) << c.name;
  }
  EXPECT_EQ(names, color_codec_names());
  EXPECT_EQ(join(names), "jpeg, raw, none, h264");
}

TEST_F(CodecRegistry, RegisteringTheVideoCodecsTwiceChangesNothing) {
  const size_t depth = all_depth_codecs().size(), color = all_color_codecs().size();
  register_video_codecs();
  EXPECT_EQ(all_depth_codecs().size(), depth);
  EXPECT_EQ(all_color_codecs().size(), color);
}

TEST_F(CodecRegistry, EveryLosslessCodecRoundTripsRealFramesBitExactly) {
  int lossless = 0;
  for (const DepthCodecInfo& c : all_depth_codecs()) {
    if (!c.lossless) continue;
    ++lossless;
    EXPECT_EQ(c.max_error_mm, 0) << c.name;
    for (const auto& [set, frames] : real_sequences()) {
      auto enc = c.make_encoder();
      auto dec = c.make_decoder();
      std::vector<uint8_t> bytes;
      DepthImage out;
      for (size_t i = 0; i < frames.size(); ++i) {
        enc->encode(frames[i], i == 0, bytes);
        ASSERT_GE(bytes.size(), kDepthHeaderBytes);
        EXPECT_EQ(bytes[3], c.wire_id) << c.name;  // the header names the codec it was made by
        dec->decode(bytes, out);
        ASSERT_EQ(out, frames[i]) << c.name << " on " << set << " frame " << i;
      }
    }
  }
  EXPECT_EQ(lossless, 7);  // raw rvl trvl zstd lz4 volcast volcast-t
}

TEST_F(CodecRegistry, EveryNearLosslessCodecStaysWithinItsBoundOnEveryPixel) {
  int near_lossless = 0;
  for (const DepthCodecInfo& c : all_depth_codecs()) {
    if (c.max_error_mm <= 0) continue;
    ++near_lossless;
    EXPECT_FALSE(c.lossless) << c.name;
    int worst = 0;
    for (const auto& [set, frames] : real_sequences()) {
      auto enc = c.make_encoder();
      auto dec = c.make_decoder();
      std::vector<uint8_t> bytes;
      DepthImage out;
      for (size_t i = 0; i < frames.size(); ++i) {
        enc->encode(frames[i], i == 0, bytes);
        EXPECT_EQ(bytes[3], c.wire_id) << c.name;
        EXPECT_EQ(bytes[5], c.max_error_mm) << c.name;  // the bound travels in header byte 5
        dec->decode(bytes, out);
        ASSERT_EQ(out.width, frames[i].width);
        ASSERT_EQ(out.height, frames[i].height);
        // One check per pixel, an assertion only for the first that fails (two assertions per
        // pixel were a fifth of this test's time under the sanitizers).
        for (size_t p = 0; p < out.size(); ++p) {
          const int source = frames[i].pixels[p], decoded = out.pixels[p];
          if ((decoded == 0) != (source == 0) || std::abs(decoded - source) > c.max_error_mm)
            FAIL() << c.name << " " << set << " frame " << i << " pixel " << p << ": " << decoded
                   << " mm decoded, " << source << " mm sent (bound " << c.max_error_mm
                   << " mm, 0 = invalid on both sides)";
          worst = std::max(worst, std::abs(decoded - source));
        }
      }
    }
    EXPECT_EQ(worst, c.max_error_mm) << c.name << ": the bound is reached, not loose";
  }
  EXPECT_EQ(near_lossless, 3);  // volcast-n1, -n2, -n4
}

TEST_F(CodecRegistry, TemporalCodecsDeltaFramesAreRefusedByAFreshDecoder) {
  const auto frames = test::real_depth_frames("hands", 32);
  for (const DepthCodecInfo& c : all_depth_codecs()) {
    auto enc = c.make_encoder();
    auto dec = c.make_decoder();
    std::vector<uint8_t> key, next;
    DepthImage out;
    EXPECT_TRUE(enc->encode(frames[30], true, key)) << c.name;
    EXPECT_TRUE(depth_frame_is_key(key)) << c.name;
    const bool next_is_key = enc->encode(frames[31], false, next);
    EXPECT_EQ(depth_frame_is_key(next), next_is_key) << c.name;
    EXPECT_EQ(next_is_key, !c.temporal) << c.name << ": only temporal codecs emit delta frames";
    if (c.temporal) {
      EXPECT_THROW(c.make_decoder()->decode(next, out), Error) << c.name;
    } else {
      c.make_decoder()->decode(next, out);  // any frame decodes on its own
    }
    dec->decode(key, out);
    dec->decode(next, out);  // after its key frame, the delta frame decodes
    EXPECT_EQ(out.width, frames[31].width) << c.name;
  }

  for (const ColorCodecInfo& c : all_color_codecs()) {
    auto enc = c.make_encoder();
    auto dec = c.make_decoder();
    std::vector<uint8_t> key, next;
    ColorImage out;
    EXPECT_TRUE(enc->encode(test::hands_color_image(30), true, key)) << c.name;
    EXPECT_EQ(enc->encode(test::hands_color_image(31), false, next), !c.temporal) << c.name;
    if (c.temporal) {
      EXPECT_THROW(c.make_decoder()->decode(next, out), Error) << c.name;
    } else {
      c.make_decoder()->decode(next, out);
    }
    dec->decode(key, out);
    dec->decode(next, out);
  }
}

TEST_F(CodecRegistry, LosslessColorIsExactOnARealImage) {
  const ColorImage image = test::hands_color_image(50);
  for (const ColorCodecInfo& c : all_color_codecs()) {
    if (!c.lossless) continue;
    std::vector<uint8_t> bytes;
    ColorImage out;
    c.make_encoder()->encode(image, true, bytes);
    c.make_decoder()->decode(bytes, out);
    EXPECT_EQ(out, image) << c.name;
  }
}

TEST_F(CodecRegistry, EveryCodecsFramesDeclareTheirSizeBeforeDecoding) {
  const DepthImage depth = test::real_depth_frames("kinect").front();
  for (const DepthCodecInfo& c : all_depth_codecs()) {
    std::vector<uint8_t> bytes;
    c.make_encoder()->encode(depth, true, bytes);
    const auto size = declared_depth_size(bytes);
    ASSERT_TRUE(size) << c.name;
    EXPECT_EQ(size->width, depth.width) << c.name;
    EXPECT_EQ(size->height, depth.height) << c.name;
  }
  const ColorImage color = test::hands_color_image(50);
  for (const ColorCodecInfo& c : all_color_codecs()) {
    std::vector<uint8_t> bytes;
    c.make_encoder()->encode(color, true, bytes);
    const auto size = declared_color_size(bytes);
    if (bytes.empty()) {  // none: no image
      EXPECT_FALSE(size) << c.name;
      continue;
    }
    ASSERT_TRUE(size) << c.name;
    EXPECT_EQ(size->width, color.width) << c.name;
    EXPECT_EQ(size->height, color.height) << c.name;
  }
  // Too short, or no known format: the decoder is left to refuse it.
  const std::vector<uint8_t> junk = {'V', 'D', 2, 0};
  EXPECT_FALSE(declared_depth_size(junk));
  EXPECT_FALSE(declared_color_size(junk));
  EXPECT_FALSE(declared_color_size(std::vector<uint8_t>{0xff, 0xd8, 0xff}));  // truncated JPEG
}

TEST_F(CodecRegistry, UnknownNamesGiveAnErrorListingTheAvailableCodecs) {
  EXPECT_EQ(find_depth_codec("zdepth"), nullptr);
  try {
    make_depth_encoder("zdepth");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              "unknown depth codec 'zdepth' (available: " + join(depth_codec_names()) + ")");
  }
  EXPECT_THROW(make_depth_decoder(""), Error);
  EXPECT_THROW(depth_codec_info("RVL"), Error);  // names are exact
  EXPECT_EQ(find_color_codec("webp"), nullptr);
  try {
    make_color_decoder("webp");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              "unknown color codec 'webp' (available: " + join(color_codec_names()) + ")");
  }
}

TEST_F(CodecRegistry, HelpSaysWhichCodecsAreLosslessAndBoundsTheNearLosslessOnes) {
  EXPECT_EQ(depth_codec_help(),
            "raw (lossless), rvl (lossless), trvl (lossless, temporal), zstd (lossless), "
            "lz4 (lossless), volcast (lossless), volcast-t (lossless, temporal), "
            "volcast-n1 (within 1 mm), volcast-n2 (within 2 mm), volcast-n4 (within 4 mm), "
            "h264 (lossy, temporal), hevc (lossy, temporal)");
  EXPECT_EQ(color_codec_help(), "jpeg (lossy), raw (lossless), none, h264 (lossy, temporal)");
}

TEST_F(CodecRegistry, RefusesDuplicateAndInconsistentEntries) {
  DepthCodecInfo copy = depth_codec_info("rvl");
  EXPECT_THROW(register_depth_codec(copy), Error);  // the name is taken
  copy.name = "rvl-but-lossy";
  copy.max_error_mm = -1;  // lossless, yet unbounded: inconsistent
  EXPECT_THROW(register_depth_codec(copy), Error);
  copy.max_error_mm = 0;
  copy.make_decoder = nullptr;
  EXPECT_THROW(register_depth_codec(copy), Error);
  ColorCodecInfo color = color_codec_info("h264");
  EXPECT_THROW(register_color_codec(color), Error);
  EXPECT_EQ(find_depth_codec("rvl-but-lossy"), nullptr);
}

// A tier is parsed and written one way for every flag and the server (volcast/codec/tier.hpp):
// what to_string writes parses back to the same tier, and each malformed part is named.
TEST_F(CodecRegistry, ATierParsesAndPrintsOneWayAndEachBadPartIsRefused) {
  const Tier ladder = parse_tier("h264/h264/50@2", "server: ladder rung");
  EXPECT_EQ(ladder, (Tier{"h264", "h264", 50, 2}));
  EXPECT_EQ(to_string(ladder), "h264/h264/50@2");
  for (const char* text : {"volcast/jpeg", "volcast-n2/jpeg/70", "trvl/none", "rvl/raw@8"}) {
    EXPECT_EQ(to_string(parse_tier(text, "--tier")), text);
    EXPECT_EQ(parse_tier(to_string(parse_tier(text, "--tier")), "--tier"),
              parse_tier(text, "--tier"));
  }
  // Quality 0 is the codec's default (the server took it, `record --tier` refused it): one rule.
  EXPECT_EQ(parse_tier("volcast/jpeg/0", "--tier", TierRate::kEveryFrameSet),
            (Tier{"volcast", "jpeg", 0, 1}));
  EXPECT_EQ(to_string(Tier{"volcast", "jpeg", 0, 1}), "volcast/jpeg");
  const auto error_of = [](const std::string& text, TierRate rate = TierRate::kAny) {
    try {
      parse_tier(text, "--record-tier", rate);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  for (const char* bad :
       {"volcast", "volcast/", "/jpeg", "nope/jpeg", "volcast/nope", "volcast/jpeg/101",
        "volcast/jpeg/-1", "volcast/jpeg/7x", "volcast/jpeg/1000", "volcast/jpeg@0",
        "volcast/jpeg@9", "volcast/jpeg@", "volcast/jpeg/50/1", ""}) {
    const std::string e = error_of(bad);
    EXPECT_EQ(e.rfind("--record-tier '" + std::string(bad) + "' must be DEPTH/COLOR", 0), 0u)
        << bad << ": " << e;
  }
  // A recording, a NATS tier or a client's request carries every frame set: @N is refused there,
  // by name, and only there.
  EXPECT_NE(error_of("volcast/jpeg@2", TierRate::kEveryFrameSet).find("no @N"), std::string::npos);
  EXPECT_EQ(error_of("volcast/jpeg@2"), "");
  EXPECT_EQ(error_of("volcast/jpeg/50", TierRate::kEveryFrameSet), "");
}

}  // namespace
}  // namespace volcast
