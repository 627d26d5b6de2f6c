// Lossy video codecs through libavcodec: depth as H.264 / HEVC, color as H.264. Real data from
// ../shared/data; the synthetic images are labelled.
#include <gtest/gtest.h>

#include <cmath>

#include "support/test_data.hpp"
#include "volcast/codec/color_codec.hpp"
#include "volcast/codec/depth_codec.hpp"
#include "volcast/codec_video/video_codecs.hpp"
#include "volcast/core/error.hpp"

namespace volcast {
namespace {

// Every test starts with the video codecs in the codec table, as the volcast CLI does in main().
class VideoCodecTest : public ::testing::Test {
 protected:
  void SetUp() override { register_video_codecs(); }
};
class VideoDepth : public VideoCodecTest {};
class VideoColor : public VideoCodecTest {};

struct VideoResult {
  double mean_error = 0, max_error = 0, ratio = 0;
};

// Streams `frames` (key frame first) and checks on every frame that exactly the same pixels are
// valid; returns the error over valid pixels and the compression ratio.
VideoResult stream(const std::string& codec, const std::vector<DepthImage>& frames) {
  auto enc = make_depth_encoder(codec);
  auto dec = make_depth_decoder(codec);
  std::vector<uint8_t> bytes;
  DepthImage out;
  VideoResult r;
  double error = 0, valid = 0, coded = 0, raw = 0;
  for (size_t i = 0; i < frames.size(); ++i) {
    EXPECT_EQ(enc->encode(frames[i], i == 0, bytes), i == 0) << codec << " frame " << i;
    dec->decode(bytes, out);
    coded += static_cast<double>(bytes.size());
    raw += static_cast<double>(frames[i].size() * 2);
    EXPECT_EQ(out.width, frames[i].width);
    EXPECT_EQ(out.height, frames[i].height);
    for (size_t p = 0; p < out.size(); ++p) {
      EXPECT_EQ(out.pixels[p] == 0, frames[i].pixels[p] == 0) << codec << " frame " << i;
      if (!frames[i].pixels[p]) continue;
      const double e = std::abs(double(out.pixels[p]) - double(frames[i].pixels[p]));
      error += e, valid += 1, r.max_error = std::max(r.max_error, e);
    }
  }
  r.mean_error = error / valid;
  r.ratio = raw / coded;
  return r;
}

TEST_F(VideoDepth, KeepsTheValidMaskExactAndTheErrorSmallOnRealSets) {
  // Measured (mean / max error over valid pixels): see the bench; the bounds leave a margin.
  const auto kinect = test::real_depth_frames("kinect");
  const auto hands = test::real_depth_frames("hands", 40);
  for (const std::string codec : {"h264", "hevc"}) {
    const VideoResult k = stream(codec, {kinect[0], kinect[0], kinect[0]});
    EXPECT_LT(k.mean_error, 3.0) << codec;
    EXPECT_GT(k.ratio, 20.0) << codec;  // RVL: 4.15x
    const VideoResult h = stream(codec, hands);
    EXPECT_LT(h.mean_error, 10.0) << codec;
    EXPECT_GT(h.ratio, 15.0) << codec;  // RVL: 3.50x
  }
}

TEST_F(VideoDepth, HandlesOddAndDegenerateSizes) {
  // Synthetic (labelled): 1x1, a 33x17 ramp with holes, all invalid.
  DepthImage one(1, 1), ramp(33, 17), empty(8, 6);
  one.pixels[0] = 1234;
  for (size_t i = 0; i < ramp.size(); ++i)
    ramp.pixels[i] = static_cast<uint16_t>(i % 7 ? 800 + i : 0);
  for (const std::string codec : {"h264", "hevc"}) {
    for (const DepthImage& d : {one, ramp, empty}) {
      const VideoResult r = stream(codec, {d, d});
      EXPECT_LE(r.max_error, 30.0) << codec;
    }
  }
}

TEST_F(VideoDepth, DeltaWithoutKeyFrameIsAnErrorAndAKeyFrameResynchronises) {
  const auto frames = test::real_depth_frames("hands", 4);
  for (const std::string codec : {"h264", "hevc"}) {
    auto enc = make_depth_encoder(codec);
    std::vector<uint8_t> bytes;
    enc->encode(frames[0], true, bytes);
    EXPECT_FALSE(enc->encode(frames[1], false, bytes));
    auto late = make_depth_decoder(codec);
    DepthImage out;
    EXPECT_THROW(late->decode(bytes, out), Error) << codec;
    EXPECT_TRUE(enc->encode(frames[2], true, bytes));
    EXPECT_TRUE(depth_frame_is_key(bytes));
    late->decode(bytes, out);
    EXPECT_EQ(out.width, frames[2].width);
    enc->encode(frames[3], false, bytes);
    late->decode(bytes, out);
    bytes.resize(bytes.size() - 3);  // truncated: the lengths no longer match
    EXPECT_THROW(late->decode(bytes, out), Error) << codec;
  }
}

TEST_F(VideoColor, H264StreamsRealColorClosely) {
  auto enc = make_color_encoder("h264");
  auto dec = make_color_decoder("h264");
  std::vector<uint8_t> bytes;
  ColorImage out;
  double coded = 0, raw = 0;
  for (int i = 0; i < 20; ++i) {
    const ColorImage image = test::hands_color_image(40 + i);
    EXPECT_EQ(enc->encode(image, i == 0, bytes), i == 0);
    dec->decode(bytes, out);
    ASSERT_EQ(out.width, image.width);
    ASSERT_EQ(out.height, image.height);
    double se = 0;
    for (size_t p = 0; p < out.bgra.size(); p += 4)
      for (int c = 0; c < 3; ++c) se += std::pow(double(out.bgra[p + c]) - image.bgra[p + c], 2);
    const double psnr =
        10 * std::log10(255.0 * 255.0 / (se / static_cast<double>(out.bgra.size() / 4 * 3)));
    EXPECT_GT(psnr, 30.0) << "frame " << i;
    coded += static_cast<double>(bytes.size());
    raw += static_cast<double>(image.width) * image.height * 3;
  }
  EXPECT_GT(raw / coded, 40.0);  // JPEG q90 on this set: about 17x
  // A delta frame without its key frame, and a truncated header, are errors.
  enc->encode(test::hands_color_image(70), false, bytes);
  EXPECT_THROW(make_color_decoder("h264")->decode(bytes, out), Error);
  EXPECT_THROW(dec->decode(std::span(bytes).first(5), out), Error);
  // 4:2:0 needs even sides; no color at all is sent as nothing.
  EXPECT_THROW(enc->encode(ColorImage(5, 4), true, bytes), Error);
  enc->encode(ColorImage(), true, bytes);
  EXPECT_TRUE(bytes.empty());
}

}  // namespace
}  // namespace volcast
