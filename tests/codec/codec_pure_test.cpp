// volcast_codec on its own, as the browser build will use it: this test is linked against
// volcast_codec and volcast_core only (no FFmpeg; check_codec_pure.cmake checks that), so only the
// pure codecs are in the table and the video names are unknown, with a hint. Synthetic images
// (labelled); the real-frame checks of every codec are in codec_registry_test.cpp.
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#include "volcast/codec/registry.hpp"
#include "volcast/core/error.hpp"

namespace volcast {
namespace {

TEST(CodecPure, TableHoldsThePureCodecsOnly) {
  std::string depth, color;
  for (const std::string& n : depth_codec_names()) depth += n + " ";
  for (const std::string& n : color_codec_names()) color += n + " ";
  EXPECT_EQ(depth, "raw rvl trvl zstd lz4 volcast volcast-t volcast-n1 volcast-n2 volcast-n4 ");
  EXPECT_EQ(color, "jpeg raw none ");
}

TEST(CodecPure, VideoNamesAreUnknownAndTheErrorSaysWhereTheyComeFrom) {
  for (const char* name : {"h264", "hevc"}) {
    EXPECT_EQ(find_depth_codec(name), nullptr);
    try {
      make_depth_encoder(name);
      FAIL() << name;
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_EQ(what.rfind(std::string("unknown depth codec '") + name + "' (available: raw, ", 0),
                0u)
          << what;
      EXPECT_NE(what.find("register_video_codecs()"), std::string::npos) << what;
    }
  }
  EXPECT_THROW(make_color_decoder("h264"), Error);
}

TEST(CodecPure, EveryPureDepthCodecRoundTripsWithinItsBound) {
  // Synthetic: a 37x23 ramp with invalid holes and values up to 65535.
  DepthImage image(37, 23);
  for (size_t i = 0; i < image.size(); ++i)
    image.pixels[i] = static_cast<uint16_t>(i % 11 == 0 ? 0 : (i * 2731) % 65535 + 1);
  for (const DepthCodecInfo& c : all_depth_codecs()) {
    std::vector<uint8_t> bytes;
    DepthImage out;
    c.make_encoder()->encode(image, true, bytes);
    c.make_decoder()->decode(bytes, out);
    ASSERT_EQ(out.width, image.width) << c.name;
    for (size_t p = 0; p < out.size(); ++p) {
      ASSERT_EQ(out.pixels[p] == 0, image.pixels[p] == 0) << c.name;
      ASSERT_LE(std::abs(int{out.pixels[p]} - int{image.pixels[p]}), c.max_error_mm) << c.name;
    }
  }
}

}  // namespace
}  // namespace volcast
