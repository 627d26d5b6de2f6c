// Sources: the genuine Azure Kinect recording and image-sequence folders, including bad input.
#include <gtest/gtest.h>

#include <fstream>

#include "support/sequence_folder.hpp"
#include "support/test_data.hpp"
#include "volcast/capture/image_sequence.hpp"
#include "volcast/capture/k4a_recording.hpp"
#include "volcast/capture/still_source.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/image_io.hpp"
#include "volcast/core/jpeg.hpp"

namespace volcast {
namespace {
namespace fs = std::filesystem;

using test::error_of;

TEST(K4aRecording, DecodesBigEndianDepthInAPlausibleMillimetreRange) {
  auto src = open_source(test::kinect_mkv());
  EXPECT_EQ(src->frame_count(), 1);
  const CameraFrame f = src->next();
  ASSERT_EQ(f.depth.width, 640);
  ASSERT_EQ(f.depth.height, 576);
  size_t valid = 0;
  double sum = 0;
  uint16_t lo = 65535, hi = 0;
  for (uint16_t d : f.depth.pixels) {
    if (!d) continue;
    ++valid, sum += d, lo = std::min(lo, d), hi = std::max(hi, d);
  }
  // NFOV unbinned measures 0.5-3.86 m (Azure Kinect spec); byte-swapped samples would spread over
  // the whole 16-bit range.
  EXPECT_GT(valid, f.depth.size() / 2);
  EXPECT_GE(lo, 100);
  EXPECT_LE(hi, 6000);
  EXPECT_GT(sum / static_cast<double>(valid), 300.0);
  EXPECT_LT(sum / static_cast<double>(valid), 4000.0);
}

TEST(K4aRecording, RegistersColorOntoMostValidDepthPixels) {
  auto src = open_source(test::kinect_mkv());
  const CameraFrame f = src->next();
  ASSERT_EQ(f.color.width, 640);
  ASSERT_EQ(f.color.height, 576);
  size_t valid = 0, colored = 0, colored_without_depth = 0;
  for (size_t i = 0; i < f.depth.size(); ++i) {
    const bool has_color = f.color.bgra[i * 4 + 3] == 255;
    if (f.depth.pixels[i]) {
      ++valid;
      colored += has_color;
    } else {
      colored_without_depth += has_color;
    }
  }
  EXPECT_GT(static_cast<double>(colored) / static_cast<double>(valid), 0.6);
  EXPECT_EQ(colored_without_depth, 0u);
  // Real image content, not a constant: the registered colors vary.
  double mean = 0, var = 0;
  for (size_t i = 0; i < f.depth.size(); ++i) mean += f.color.bgra[i * 4 + 1];
  mean /= static_cast<double>(f.depth.size());
  for (size_t i = 0; i < f.depth.size(); ++i) var += std::pow(f.color.bgra[i * 4 + 1] - mean, 2);
  EXPECT_GT(std::sqrt(var / static_cast<double>(f.depth.size())), 10.0);
}

TEST(K4aRecording, LoopsAndKeepsTimestampsIncreasing) {
  auto src = open_source(test::kinect_mkv());
  const CameraFrame a = src->next();
  const CameraFrame b = src->next();
  EXPECT_EQ(a.depth, b.depth);
  EXPECT_GT(b.device_timestamp_us, a.device_timestamp_us);
}

// A capture loop recycles its frames (SitePlayer): a source that reads into one must reuse its
// buffers, not allocate new ones per frame, and still deliver the frame.
TEST(Sources, ReadingIntoARecycledFrameReusesItsBuffersAndMatchesAFreshRead) {
  const fs::path four = test::data_dir() / "k4a-4cam-nfov";
  fs::path depth_png, color_png;
  for (const auto& e : fs::directory_iterator(four)) {
    const std::string name = e.path().filename().string();
    if (name.rfind("depth.", 0) == 0 && (depth_png.empty() || e.path() < depth_png)) {
      depth_png = e.path();
      color_png = four / ("rgb." + name.substr(6));
    }
  }
  ASSERT_FALSE(depth_png.empty());
  std::vector<std::unique_ptr<FrameSource>> sources;
  sources.push_back(open_source(test::kinect_mkv()));
  sources.push_back(open_still_source(depth_png, color_png, sources[0]->calibration(), 30));
  for (auto& src : sources) {
    CameraFrame f;
    src->next(f);
    ASSERT_FALSE(f.color.empty()) << src->description();
    const uint16_t* depth = f.depth.pixels.data();
    const uint8_t* color = f.color.bgra.data();
    const int64_t t0 = f.device_timestamp_us;
    f.depth.pixels[1000] ^= 1;  // what a filter might have done to the recycled frame
    src->next(f);
    EXPECT_EQ(f.depth.pixels.data(), depth) << src->description();
    EXPECT_EQ(f.color.bgra.data(), color) << src->description();
    EXPECT_GT(f.device_timestamp_us, t0);
    const CameraFrame fresh = src->next();
    EXPECT_EQ(f.depth, fresh.depth) << src->description();  // a still frame is the same each time
    EXPECT_EQ(f.color, fresh.color) << src->description();
  }
}

TEST(K4aRecording, ProbeReportsStreamsAndIntrinsics) {
  const K4aRecordingInfo info = probe_k4a_recording(test::kinect_mkv());
  EXPECT_EQ(info.depth_mode, "NFOV_UNBINNED");
  EXPECT_EQ(info.color_mode, "MJPG_720P");
  EXPECT_EQ(info.depth_frames, 1);
  EXPECT_DOUBLE_EQ(info.fps, 5.0);  // recorded at 5 fps
  EXPECT_EQ(info.color_frames, 1);
  ASSERT_GE(info.streams.size(), 4u);
  EXPECT_EQ(info.streams[1].title, "DEPTH");
  EXPECT_EQ(info.streams[1].codec, "b16g");
  EXPECT_EQ(info.color_intrinsics.width, 1280);
}

TEST(K4aRecording, RejectsMissingCorruptAndTruncatedFiles) {
  const fs::path dir = test::temp_dir("bad_mkv");
  EXPECT_NE(error_of([&] { open_source(dir / "missing.mkv"); }).find("does not exist"),
            std::string::npos);

  std::ofstream(dir / "garbage.mkv") << "this is not a matroska file at all";
  EXPECT_NE(error_of([&] { open_source(dir / "garbage.mkv"); }).find("garbage.mkv"),
            std::string::npos);

  // The real recording cut at several points: every cut is an error naming the file, never a crash.
  std::ifstream in(test::kinect_mkv(), std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  // A cut past the capture's packets (into the IR/IMU data) keeps the whole capture: nothing
  // recorded is lost.
  const DepthImage complete = open_source(test::kinect_mkv())->next().depth;
  int errors = 0;
  for (double fraction : {0.02, 0.1, 0.3, 0.5, 0.7, 0.9, 0.99}) {
    const fs::path cut = dir / "truncated.mkv";
    std::ofstream(cut, std::ios::binary)
        .write(bytes.data(),
               static_cast<std::streamsize>(static_cast<double>(bytes.size()) * fraction));
    DepthImage got;
    const std::string err = error_of([&] { got = open_source(cut)->next().depth; });
    if (err.empty()) {
      EXPECT_EQ(got, complete) << "cut at " << fraction << " decoded without error but differs";
    } else {
      ++errors;
      EXPECT_NE(err.find("truncated.mkv"), std::string::npos)
          << "cut at " << fraction << ": '" << err << "'";
    }
  }
  EXPECT_GE(errors, 2);
  EXPECT_NE(error_of([&] { open_source(dir); }).find("depth/"), std::string::npos);
  EXPECT_NE(error_of([&] { open_source(test::data_dir() / "README.md"); }).find("neither"),
            std::string::npos);
}

TEST(ImageSequence, ReadsTheRealHandsSequenceAndLoops) {
  SourceOptions opt;
  opt.intrinsics = Intrinsics{0, 0, 460, 460, 320, 180};
  auto src = open_source(test::hands_dir(), opt);
  EXPECT_EQ(src->frame_count(), 207);
  EXPECT_DOUBLE_EQ(src->calibration().depth.fx, 460);
  EXPECT_EQ(src->calibration().depth.width, 640);
  const CameraFrame first = src->next();
  EXPECT_EQ(first.depth, read_depth_png(test::hands_dir() / "depth" / "00000.png"));
  EXPECT_EQ(first.color.width, 640);
  for (int i = 1; i < 207; ++i) src->next();
  EXPECT_EQ(src->next().depth, first.depth);  // frame 207 is frame 0 again
}

TEST(ImageSequence, ReadsIntrinsicsJsonAndRejectsMalformedOnes) {
  // Synthetic folder layout (labelled): two real hands frames plus a hand-written intrinsics.json.
  const fs::path dir = test::temp_dir("seq");
  fs::create_directories(dir / "depth");
  fs::copy_file(test::hands_dir() / "depth" / "00000.png", dir / "depth" / "a.png");
  fs::copy_file(test::hands_dir() / "depth" / "00001.png", dir / "depth" / "b.png");
  std::ofstream(dir / "intrinsics.json")
      << R"({"fx": 500, "fy": 501, "cx": 319.5, "cy": 179.5, "fps": 15,
             "world_from_camera": {"rotation": [1,0,0, 0,1,0, 0,0,1], "translation": [0.5, 0, 0]}})";
  auto src = open_source(dir);
  EXPECT_DOUBLE_EQ(src->calibration().depth.fy, 501);
  EXPECT_DOUBLE_EQ(src->fps(), 15);
  EXPECT_DOUBLE_EQ(src->calibration().world_from_camera.translation.x(), 0.5);
  EXPECT_TRUE(src->next().color.empty());  // no color folder: depth only

  std::ofstream(dir / "intrinsics.json") << R"({"fx": 500})";
  EXPECT_NE(error_of([&] { open_source(dir); }).find("intrinsics.json"), std::string::npos);
  std::ofstream(dir / "intrinsics.json") << "{";
  EXPECT_NE(error_of([&] { open_source(dir); }).find("intrinsics.json"), std::string::npos);
}

TEST(ImageSequence, WithoutIntrinsicsUsesANominalPinhole) {
  auto src = open_source(test::hands_dir());
  EXPECT_NEAR(src->calibration().depth.fx, 457.0, 0.5);  // 70 degrees horizontal field of view
}

TEST(ImageSequence, RejectsACorruptDepthPng) {
  const fs::path dir = test::temp_dir("seq_bad");
  fs::create_directories(dir / "depth");
  fs::copy_file(test::hands_dir() / "depth" / "00000.png", dir / "depth" / "a.png");
  std::ifstream in(test::hands_dir() / "depth" / "00001.png", std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::ofstream(dir / "depth" / "b.png", std::ios::binary)
      .write(bytes.data(), static_cast<std::streamsize>(bytes.size() / 2));
  auto src = open_source(dir);
  src->next();
  EXPECT_NE(error_of([&] { src->next(); }).find("b.png"), std::string::npos);
}

TEST(ImageSequence, SkipsAnUnreadableFrameAndReadsTheNextOne) {
  const fs::path dir = test::hands_sequence(test::temp_dir("seq_skip"), 4, true);
  const fs::path bad = test::break_depth(dir, 1, test::BadDepth::kOtherSize);
  auto src = open_source(dir, test::hands_options(30));
  EXPECT_EQ(src->next().depth, read_depth_png(test::hands_depth(0)));
  const std::string err = error_of([&] { src->next(); });
  EXPECT_NE(err.find(bad.string() + "' is 320x180, the sequence's depth frames are 640x360"),
            std::string::npos)
      << err;
  EXPECT_EQ(src->next().depth, read_depth_png(test::hands_depth(2)));  // not frame 1 again
}

TEST(ImageSequence, ReportsFramesWithoutColorAndChecksEveryFrame) {
  const fs::path dir = test::hands_sequence(test::temp_dir("seq_check"), 6, true, {2});
  const fs::path bad = test::break_depth(dir, 4, test::BadDepth::kEightBit);
  auto src = open_source(dir, test::hands_options(30));
  EXPECT_EQ(src->frame_count(), 6);
  EXPECT_EQ(src->color_frame_count(), 5);
  int calls = 0;
  const FrameCheck check = check_frames(*src, [&](int done, int total) {
    EXPECT_EQ(done, ++calls);
    EXPECT_EQ(total, 6);
  });
  EXPECT_EQ(check.frames, 6);
  EXPECT_EQ(check.frames_without_color, 1);
  ASSERT_EQ(check.bad.size(), 1u);
  EXPECT_EQ(check.bad[0].index, 4);
  EXPECT_NE(check.bad[0].error.find(bad.string()), std::string::npos) << check.bad[0].error;
  EXPECT_NE(check.bad[0].error.find("16-bit"), std::string::npos) << check.bad[0].error;
}

TEST(ImageSequence, RefusesAnInvalidFrameRateOrIntrinsicsNamingTheFileAndValue) {
  // Synthetic intrinsics.json files (labelled) beside two real hands depth frames.
  const fs::path dir = test::hands_sequence(test::temp_dir("seq_fps"), 2, false);
  const std::string file = (dir / "intrinsics.json").string();
  const std::pair<std::string, std::string> cases[] = {
      {R"("fps": 0)", "fps must be a number in (0, 1000], got 0"},
      {R"("fps": -5)", "got -5"},
      {R"("fps": 1e9)", "got 1e+09"},
      {R"("fps": 1e999)", "1e999"},  // JSON has no infinity: refused by the parser
      {R"("fps": "NaN")", "fps must be a number, got \"NaN\""},
      {R"("fps": 30, "cx": null)", "cx must be a number, got null"},
  };
  for (const auto& [field, want] : cases) {
    std::ofstream(file) << R"({"fx": 460, "fy": 460, "cx": 320, "cy": 180, )" << field << "}";
    const std::string err = error_of([&] { open_source(dir); });
    EXPECT_NE(err.find(file), std::string::npos) << field << ": " << err;
    EXPECT_NE(err.find(want), std::string::npos) << field << ": " << err;
  }
  std::ofstream(file) << R"({"fx": -460, "fy": 460, "cx": 320, "cy": 180})";
  EXPECT_NE(error_of([&] { open_source(dir); }).find("fx and fy must be > 0, got -460"),
            std::string::npos);
  fs::remove(file);
  SourceOptions opt = test::hands_options(0);
  EXPECT_NE(error_of([&] { open_source(dir, opt); }).find("got 0"), std::string::npos);
  opt.fps = 30;
  EXPECT_EQ(error_of([&] { open_source(dir, opt); }), "");
}

TEST(ImageDecoders, RefuseAHugeSizeBeforeAllocatingAndNameIt) {
  const fs::path dir = test::temp_dir("huge");
  test::write_png_header_claiming(dir / "huge.png", 20000, 20000);  // 57 bytes
  EXPECT_EQ(fs::file_size(dir / "huge.png"), 57u);
  std::string err = error_of([&] { read_depth_png(dir / "huge.png"); });
  EXPECT_NE(err.find("huge.png' claims 20000x20000 pixels"), std::string::npos) << err;
  err = error_of([&] { read_color_png(dir / "huge.png"); });
  EXPECT_NE(err.find("20000x20000"), std::string::npos) << err;
  // The largest accepted size gets past the header (and fails for its missing data instead).
  test::write_png_header_claiming(dir / "max.png", kMaxImageSide, 1);
  err = error_of([&] { read_depth_png(dir / "max.png"); });
  EXPECT_EQ(err.find("claims"), std::string::npos) << err;
  EXPECT_NE(err.find("max.png"), std::string::npos) << err;

  // A real JPEG whose frame header is patched (synthetic) to claim 10000 x 10000.
  std::ifstream in(test::hands_color(0), std::ios::binary);
  std::vector<uint8_t> jpeg((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  size_t sof = 0;
  for (size_t i = 0; i + 9 < jpeg.size() && !sof; ++i)
    if (jpeg[i] == 0xff && (jpeg[i + 1] == 0xc0 || jpeg[i + 1] == 0xc2)) sof = i;
  ASSERT_GT(sof, 0u);
  for (size_t at : {sof + 5, sof + 7}) jpeg[at] = 10000 >> 8, jpeg[at + 1] = 10000 & 0xff;
  ColorImage out;
  err = error_of([&] { decode_jpeg(jpeg, out); });
  EXPECT_NE(err.find("JPEG claims 10000x10000 pixels"), std::string::npos) << err;
  EXPECT_TRUE(out.bgra.empty());
}

TEST(ImageDecoders, TruncatedJpegAndPngAreErrorsNotGreyFrames) {
  std::ifstream in(test::hands_color(0), std::ios::binary);
  const std::vector<uint8_t> jpeg((std::istreambuf_iterator<char>(in)),
                                  std::istreambuf_iterator<char>());
  ColorImage out;
  decode_jpeg(jpeg, out);  // whole: fine
  for (double fraction : {0.3, 0.6, 0.9, 0.99}) {
    const auto cut =
        std::span(jpeg).first(static_cast<size_t>(static_cast<double>(jpeg.size()) * fraction));
    const std::string err = error_of([&] { decode_jpeg(cut, out); });
    EXPECT_NE(err.find("corrupt JPEG"), std::string::npos) << fraction << ": '" << err << "'";
  }
  const fs::path dir = test::hands_sequence(test::temp_dir("truncated"), 1, false);
  const fs::path png = test::break_depth(dir, 0, test::BadDepth::kTruncated);
  const std::string err = error_of([&] { read_depth_png(png); });
  EXPECT_NE(err.find("truncated PNG '" + png.string() + "'"), std::string::npos) << err;
}

TEST(ImageSequence, ATruncatedColorJpegMakesTheFrameUnreadable) {
  const fs::path dir = test::hands_sequence(test::temp_dir("seq_bad_jpeg"), 3, true);
  const fs::path jpg = dir / "color" / test::hands_color(1).filename();
  fs::remove(jpg);
  std::ifstream in(test::hands_color(1), std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::ofstream(jpg, std::ios::binary)
      .write(bytes.data(), static_cast<std::streamsize>(bytes.size() * 2 / 3));
  auto src = open_source(dir, test::hands_options(30));
  src->next();
  const std::string err = error_of([&] { src->next(); });
  EXPECT_NE(err.find(jpg.string()), std::string::npos) << err;
  EXPECT_NE(err.find("corrupt JPEG"), std::string::npos) << err;
  EXPECT_EQ(src->next().color.width, 640);
}

}  // namespace
}  // namespace volcast
