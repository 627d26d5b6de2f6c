// Depth codecs (RVL, temporal RVL, raw) and color codecs: exactness on real and synthetic frames,
// key frames and drops, and rejection of corrupt streams.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <random>

#include "support/test_data.hpp"
#include "volcast/codec/color_codec.hpp"
#include "volcast/codec/depth_codec.hpp"
#include "volcast/codec/registry.hpp"
#include "volcast/codec_video/video_codecs.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/jpeg.hpp"

namespace volcast {
namespace {

// Encodes and decodes `frames` in order (key frame first). bound 0: every frame must come back
// bit-exact; bound N: every valid pixel within N mm and exactly the same pixels valid.
void expect_within(const std::string& codec, int bound, const std::vector<DepthImage>& frames,
                   const std::string& set) {
  auto enc = make_depth_encoder(codec);
  auto dec = make_depth_decoder(codec);
  std::vector<uint8_t> bytes;
  DepthImage out;
  for (size_t i = 0; i < frames.size(); ++i) {
    enc->encode(frames[i], i == 0, bytes);
    dec->decode(bytes, out);
    if (bound == 0) {
      ASSERT_EQ(out, frames[i]) << codec << " on " << set << " frame " << i;
      continue;
    }
    ASSERT_EQ(out.width, frames[i].width);
    ASSERT_EQ(out.height, frames[i].height);
    // The first pixel out of bound (or valid on one side only), then one assertion: two per
    // pixel (207 frames of 368,640 pixels, three codecs) were a sixth of the test's time.
    const auto bad =
        std::mismatch(out.pixels.begin(), out.pixels.end(), frames[i].pixels.begin(),
                      [&](uint16_t a, uint16_t b) {
                        return (a == 0) == (b == 0) && std::abs(int{a} - int{b}) <= bound;
                      });
    ASSERT_TRUE(bad.first == out.pixels.end())
        << codec << " " << set << " frame " << i << " pixel " << (bad.first - out.pixels.begin())
        << ": " << *bad.first << " mm decoded, " << *bad.second << " mm sent (bound " << bound
        << " mm, 0 = invalid on both sides)";
  }
}

void expect_round_trip(const std::string& codec, const std::vector<DepthImage>& frames,
                       const std::string& set) {
  expect_within(codec, 0, frames, set);
}

int near_bound(const std::string& codec) {
  return codec.rfind("volcast-n", 0) == 0 ? std::stoi(codec.substr(9)) : 0;
}

class RealSets : public ::testing::TestWithParam<std::string> {};

TEST_P(RealSets, RvlAndTemporalRvlRoundTripBitExactlyOnEveryFrame) {
  const auto frames = test::real_depth_frames(GetParam());
  ASSERT_FALSE(frames.empty());
  expect_round_trip("rvl", frames, GetParam());
  expect_round_trip("trvl", frames, GetParam());
  expect_round_trip("raw", frames, GetParam());
  expect_round_trip("zstd", frames, GetParam());
  expect_round_trip("lz4", frames, GetParam());
  expect_round_trip("volcast", frames, GetParam());
  expect_round_trip("volcast-t", frames, GetParam());  // every frame after the first a delta
}

TEST_P(RealSets, NearLosslessVolcastStaysWithinItsBoundOnEveryPixel) {
  const auto frames = test::real_depth_frames(GetParam());
  for (const std::string codec : {"volcast-n1", "volcast-n2", "volcast-n4"})
    expect_within(codec, near_bound(codec), frames, GetParam());
}

INSTANTIATE_TEST_SUITE_P(SharedData, RealSets,
                         ::testing::Values("hands", "kinect", "4cam", "binned"));

TEST(Rvl, CompressesRealDepth) {
  const auto frames = test::real_depth_frames("kinect");
  std::vector<uint8_t> bytes;
  make_depth_encoder("rvl")->encode(frames[0], true, bytes);
  const double ratio =
      static_cast<double>(frames[0].size() * 2) / static_cast<double>(bytes.size());
  EXPECT_GT(ratio, 3.0);  // Wilson 2017 reports ~3-4x on Kinect depth
}

// Synthetic frames (labelled): values across the whole 16-bit range, including above 32767 where
// a signed-16-bit RVL would fail, and the largest possible jumps between neighbours.
DepthImage synthetic_full_range(uint32_t seed) {
  DepthImage d(97, 61);
  std::mt19937 rng(seed);
  for (size_t i = 0; i < d.size(); ++i) {
    switch (i % 5) {
      case 0:
        d.pixels[i] = 65535;
        break;
      case 1:
        d.pixels[i] = 1;
        break;
      case 2:
        d.pixels[i] = 0;
        break;
      default:
        d.pixels[i] = static_cast<uint16_t>(rng());
    }
  }
  return d;
}

TEST(Rvl, RoundTripsValuesAbove32767) {
  expect_round_trip("rvl", {synthetic_full_range(1), synthetic_full_range(2)}, "synthetic");
}

TEST(VolcastCodec, RoundTripsValuesAbove32767AndMaximalJumps) {
  DepthImage b = synthetic_full_range(8);
  for (auto& v : b.pixels) v = v ? static_cast<uint16_t>(65536 - v) : 0;
  expect_round_trip("volcast", {synthetic_full_range(7), b}, "synthetic");
}

TEST(DepthCodecs, RoundTripDegenerateImages) {
  // Synthetic (labelled): 1x1, a single column, all invalid, all valid and constant, all 65535.
  DepthImage one = DepthImage(1, 1), column(1, 50), empty(64, 48), flat(64, 48), top(33, 17);
  one.pixels[0] = 1234;
  for (int y = 0; y < 50; ++y) column.at(0, y) = static_cast<uint16_t>(y % 3 ? 1000 + y * 7 : 0);
  std::fill(flat.pixels.begin(), flat.pixels.end(), uint16_t{900});
  std::fill(top.pixels.begin(), top.pixels.end(), uint16_t{65535});
  for (const std::string& codec : depth_codec_names()) {
    if (codec == "h264" || codec == "hevc") continue;  // lossy video: video_codec_test.cpp
    if (near_bound(codec)) {
      expect_within(codec, near_bound(codec), {one, column, empty, flat, top}, "degenerate");
    } else {
      expect_round_trip(codec, {one, column, empty, flat, top}, "degenerate");
    }
  }
}

TEST(VolcastCodec, BeatsThePapersTemporalRvlRatioLosslessly) {
  // Issue goals: >= 7.5x on the Azure Kinect frame, >= 6.5x on the hands sequence (RVL: 4.15x and
  // 3.50x; the paper's lossy temporal RVL: 7.45x).
  auto ratio = [](const std::vector<DepthImage>& frames) {
    auto enc = make_depth_encoder("volcast");
    std::vector<uint8_t> bytes;
    double raw = 0, coded = 0;
    for (const auto& f : frames) {
      enc->encode(f, true, bytes);
      raw += static_cast<double>(f.size() * 2);
      coded += static_cast<double>(bytes.size());
    }
    return raw / coded;
  };
  EXPECT_GE(ratio(test::real_depth_frames("kinect")), 7.5);
  EXPECT_GE(ratio(test::real_depth_frames("hands")), 6.5);
}

TEST(VolcastCodec, NearLosslessWithin2mmReaches12xOnTheKinectFrame) {
  // Issue goal: >= 12x with a guaranteed 2 mm bound (JPEG-LS NEAR=2: 11.44x).
  const auto frame = test::real_depth_frames("kinect")[0];
  std::vector<uint8_t> bytes;
  make_depth_encoder("volcast-n2")->encode(frame, true, bytes);
  EXPECT_GE(static_cast<double>(frame.size() * 2) / static_cast<double>(bytes.size()), 12.0);
  expect_within("volcast-n2", 2, {synthetic_full_range(9)}, "synthetic full range");
}

TEST(VolcastCodec, NearLosslessBoundHoldsForEveryDepthValue) {
  // Synthetic (labelled): a 256x256 image holding every uint16 value once, in order and shuffled
  // (smooth ramps and maximal jumps), so the quantiser is checked exhaustively.
  DepthImage ramp(256, 256);
  for (size_t i = 0; i < ramp.size(); ++i) ramp.pixels[i] = static_cast<uint16_t>(i);
  DepthImage shuffled = ramp;
  std::shuffle(shuffled.pixels.begin(), shuffled.pixels.end(), std::mt19937(11));
  for (const std::string codec : {"volcast-n1", "volcast-n2", "volcast-n4"})
    expect_within(codec, near_bound(codec), {ramp, shuffled}, "every uint16 value");
}

TEST(VolcastTemporal, ResynchronisesAtKeyFramesAndRefusesDeltasWithoutTheirReference) {
  const auto frames = test::real_depth_frames("hands", 8);
  ASSERT_GE(frames.size(), 8u);
  auto enc = make_depth_encoder("volcast-t");
  std::vector<std::vector<uint8_t>> streams(8);
  for (size_t i = 0; i < 8; ++i)
    EXPECT_EQ(enc->encode(frames[i], i % 4 == 0, streams[i]), i % 4 == 0) << i;
  DepthImage out;
  auto dec = make_depth_decoder("volcast-t");
  EXPECT_THROW(dec->decode(streams[1], out), Error);  // no key frame yet
  dec->decode(streams[0], out);
  EXPECT_EQ(out, frames[0]);
  EXPECT_THROW(dec->decode(streams[2], out), Error);  // frame 1 was lost
  EXPECT_THROW(dec->decode(streams[1], out), Error);  // and after a refusal, until a key frame
  dec->decode(streams[4], out);                       // the next key frame
  for (size_t i = 4; i < 8; ++i) {
    dec->decode(streams[i], out);
    EXPECT_EQ(out, frames[i]) << i;
  }
  // A corrupt delta frame is refused or decodes to something; either way the next delta frame
  // is not decoded against a reference that may be wrong.
  auto bad = make_depth_decoder("volcast-t");
  bad->decode(streams[4], out);
  std::vector<uint8_t> corrupt = streams[5];
  corrupt.resize(corrupt.size() / 2);
  EXPECT_THROW(bad->decode(corrupt, out), Error);
  EXPECT_THROW(bad->decode(streams[6], out), Error);
}

TEST(VolcastTemporal, PredictingFromTheLastFrameShrinksConsecutiveFrames) {
  // Real consecutive Azure Kinect frames (key, delta pairs): temporal blocks must pay off.
  const auto frames = test::real_depth_frames("binned");
  ASSERT_GE(frames.size(), 2u);
  auto spatial = make_depth_encoder("volcast");
  auto temporal = make_depth_encoder("volcast-t");
  std::vector<uint8_t> a, b;
  size_t spatial_bytes = 0, temporal_bytes = 0;
  for (size_t i = 0; i + 1 < frames.size(); i += 2) {
    spatial->encode(frames[i + 1], true, a);
    temporal->encode(frames[i], true, b);
    temporal->encode(frames[i + 1], false, b);
    spatial_bytes += a.size();
    temporal_bytes += b.size();
  }
  EXPECT_LT(static_cast<double>(temporal_bytes), 0.97 * static_cast<double>(spatial_bytes));
}

TEST(BytePlaneCodecs, RoundTripValuesAbove32767AndCompressRealDepth) {
  for (const std::string codec : {"zstd", "lz4"}) {
    expect_round_trip(codec, {synthetic_full_range(5), synthetic_full_range(6)}, "synthetic");
    const auto frames = test::real_depth_frames("kinect");
    std::vector<uint8_t> bytes;
    make_depth_encoder(codec)->encode(frames[0], true, bytes);
    EXPECT_GT(static_cast<double>(frames[0].size() * 2) / static_cast<double>(bytes.size()), 2.0)
        << codec;
  }
}

TEST(TemporalRvl, RoundTripsValuesAbove32767AndMaximalChanges) {
  DepthImage a = synthetic_full_range(3), b = a;
  for (auto& v : b.pixels) v = static_cast<uint16_t>(65535 - v);  // every pixel jumps, up to 65535
  expect_round_trip("trvl", {a, b, a, synthetic_full_range(4)}, "synthetic");
}

TEST(TemporalRvl, StaysExactAcrossDroppedFrames) {
  // The encoder only sees the frames the viewer receives; deltas refer to the last one it sent.
  const auto frames = test::real_depth_frames("hands");
  auto enc = make_depth_encoder("trvl");
  auto dec = make_depth_decoder("trvl");
  std::vector<uint8_t> bytes;
  DepthImage out;
  size_t sent = 0, keys = 0;
  for (size_t i = 0; i < frames.size(); i += 1 + (i % 4)) {  // drops 0, 1, 2 or 3 frames at a time
    keys += enc->encode(frames[i], sent == 0, bytes);
    EXPECT_EQ(depth_frame_is_key(bytes), sent == 0);
    dec->decode(bytes, out);
    ASSERT_EQ(out, frames[i]) << "frame " << i;
    ++sent;
  }
  EXPECT_EQ(keys, 1u);
  EXPECT_GT(sent, 50u);
}

TEST(TemporalRvl, KeyFrameResynchronisesANewDecoder) {
  const auto frames = test::real_depth_frames("hands", 4);
  auto enc = make_depth_encoder("trvl");
  std::vector<uint8_t> bytes;
  enc->encode(frames[0], true, bytes);
  enc->encode(frames[1], false, bytes);
  auto late = make_depth_decoder("trvl");
  DepthImage out;
  EXPECT_THROW(late->decode(bytes, out), Error);  // a delta without its key frame
  enc->encode(frames[2], true, bytes);
  late->decode(bytes, out);
  EXPECT_EQ(out, frames[2]);
  enc->encode(frames[3], false, bytes);
  late->decode(bytes, out);
  EXPECT_EQ(out, frames[3]);
}

TEST(TemporalRvl, UnchangedPixelsCostAlmostNothing) {
  // A static scene (the real Azure Kinect frame, replayed as its recording loops).
  const auto frames = test::real_depth_frames("kinect");
  auto enc = make_depth_encoder("trvl");
  std::vector<uint8_t> key, delta;
  enc->encode(frames[0], true, key);
  enc->encode(frames[0], false, delta);
  EXPECT_LT(delta.size(), 32u);
  EXPECT_GT(key.size(), 10'000u);
}

TEST(TemporalRvl, LossyThresholdsBoundTheErrorOnChangedPixels) {
  // The paper's lossy setting: changes of at most 10 mm are not sent.
  const auto frames = test::real_depth_frames("hands", 30);
  auto enc = make_trvl_encoder({10, 0});
  auto dec = make_depth_decoder("trvl");
  std::vector<uint8_t> bytes;
  DepthImage out;
  for (size_t i = 0; i < 30; ++i) {
    enc->encode(frames[i], i == 0, bytes);
    dec->decode(bytes, out);
    for (size_t p = 0; p < out.size(); ++p) {
      const int source = frames[i].pixels[p], decoded = out.pixels[p];
      if ((decoded == 0) != (source == 0) || std::abs(decoded - source) > 10)
        FAIL() << "frame " << i << " pixel " << p << ": " << decoded << " mm decoded, " << source
               << " mm sent (threshold 10 mm, 0 = invalid on both sides)";
    }
  }
}

TEST(DepthCodecs, UnknownNamesAreRejectedWithTheList) {
  try {
    make_depth_encoder("zdepth9");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("rvl"), std::string::npos);
  }
  EXPECT_THROW(make_depth_decoder(""), Error);
  EXPECT_THROW(make_color_encoder("webp"), Error);
}

TEST(DepthCodecs, RejectTruncatedAndBitFlippedRealStreams) {
  register_video_codecs();  // h264 and hevc too
  const auto frames = test::real_depth_frames("hands", 22);
  for (const std::string& codec : depth_codec_names()) {
    auto enc = make_depth_encoder(codec);
    std::vector<uint8_t> key, delta;
    enc->encode(frames[20], true, key);
    enc->encode(frames[21], false, delta);
    DepthImage out;
    for (size_t cut : {size_t{0}, size_t{5}, size_t{12}, key.size() / 2, key.size() - 4}) {
      auto dec = make_depth_decoder(codec);
      EXPECT_THROW(dec->decode(std::span(key).first(cut), out), Error)
          << codec << " cut at " << cut;
    }
    // Bit flips: either an error or some frame of the right size; never out-of-bounds (ASan).
    // 48 trials, each count of flips 6 times (the fuzzers, scripts/fuzz.sh, flip far more).
    std::mt19937 rng(7);
    for (int trial = 0; trial < 48; ++trial) {
      auto dec = make_depth_decoder(codec);
      std::vector<uint8_t> bad = trial % 2 ? key : delta;
      if (trial % 2 == 0) dec->decode(key, out);
      for (int f = 0; f < 1 + trial % 8; ++f)
        bad[rng() % bad.size()] ^= static_cast<uint8_t>(1u << (rng() % 8));
      try {
        dec->decode(bad, out);
        EXPECT_EQ(out.size(), static_cast<size_t>(out.width) * out.height);
      } catch (const Error&) {
      }
    }
    auto other = make_depth_decoder(codec == "rvl" ? "raw" : "rvl");
    EXPECT_THROW(other->decode(key, out), Error);  // a stream of another codec
  }
}

TEST(ColorCodecs, JpegRoundTripsRealColorClosely) {
  ColorImage image;
  std::ifstream in(test::hands_dir() / "color" / "00050.jpg", std::ios::binary);
  const std::vector<uint8_t> file((std::istreambuf_iterator<char>(in)),
                                  std::istreambuf_iterator<char>());
  decode_jpeg(file, image);
  std::vector<uint8_t> bytes;
  make_color_encoder("jpeg")->encode(image, true, bytes);
  ColorImage out;
  make_color_decoder("jpeg")->decode(bytes, out);
  ASSERT_EQ(out.width, image.width);
  double se = 0;
  for (size_t i = 0; i < out.bgra.size(); i += 4)
    for (int c = 0; c < 3; ++c) se += std::pow(double(out.bgra[i + c]) - image.bgra[i + c], 2);
  const double psnr =
      10 * std::log10(255.0 * 255.0 / (se / static_cast<double>(out.bgra.size() / 4 * 3)));
  EXPECT_GT(psnr, 32.0);
  EXPECT_LT(bytes.size(), image.bgra.size() / 8);
  // Corrupt JPEG data is an error, not a crash.
  EXPECT_THROW(make_color_decoder("jpeg")->decode(std::span(bytes).first(10), out), Error);
}

TEST(ColorCodecs, RawIsExactAndChecksItsSize) {
  ColorImage image(5, 3);
  for (size_t i = 0; i < image.bgra.size(); ++i) image.bgra[i] = static_cast<uint8_t>(i * 7);
  std::vector<uint8_t> bytes;
  make_color_encoder("raw")->encode(image, true, bytes);
  ColorImage out;
  make_color_decoder("raw")->decode(bytes, out);
  EXPECT_EQ(out, image);
  bytes.pop_back();
  EXPECT_THROW(make_color_decoder("raw")->decode(bytes, out), Error);
  // The 12-byte header as color_codec.hpp writes it down, byte for byte.
  const std::vector<uint8_t> head(bytes.begin(), bytes.begin() + kColorHeaderBytes);
  EXPECT_EQ(head, (std::vector<uint8_t>{'V', 'C', 1, 0, 0, 0, 0, 0, 5, 0, 3, 0}));
}

TEST(ColorCodecs, TheColorHeaderHasOneWriterAndOneReader) {
  std::vector<uint8_t> bytes(kColorHeaderBytes);
  write_color_header({kColorCodecH264, true, 1280, 720}, bytes);
  EXPECT_EQ(bytes, (std::vector<uint8_t>{'V', 'C', 1, 2, 1, 0, 0, 0, 0x00, 0x05, 0xd0, 0x02}));
  const auto h = read_color_header(bytes);
  ASSERT_TRUE(h);
  EXPECT_EQ(h->codec_id, kColorCodecH264);
  EXPECT_TRUE(h->key);
  EXPECT_EQ(h->width, 1280);
  EXPECT_EQ(h->height, 720);
  EXPECT_EQ(declared_color_size(bytes)->width, 1280);
  bytes[2] = 2;  // another version: not ours to read
  EXPECT_FALSE(read_color_header(bytes));
  bytes[2] = 1;
  EXPECT_FALSE(read_color_header(std::span(bytes).first(11)));
  std::vector<uint8_t> short_out(11);
  EXPECT_THROW(write_color_header({}, short_out), Error);
}

}  // namespace
}  // namespace volcast
