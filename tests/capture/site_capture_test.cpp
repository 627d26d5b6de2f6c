// A site whose cameras hit unreadable frames: the bad camera skips them (one warning per file) and
// repeats its last good frame, is marked failed after N in a row and recovers; the other cameras
// never stop. Folders are symlinks to the real hands sequence with chosen files replaced (the
// replacements are synthetic bad files, labelled as such in sequence_folder.hpp). Also: frames
// recycled, and each camera paced at its own rate on a clock the test steps.
#include <gtest/gtest.h>

#include <condition_variable>
#include <deque>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>

#include "support/sequence_folder.hpp"
#include "support/stepped_clock.hpp"
#include "support/test_data.hpp"
#include "support/test_paths.hpp"
#include "volcast/pipeline/sender.hpp"

namespace volcast {
namespace {
namespace fs = std::filesystem;

constexpr double kFps = 100;  // every source and the site: each frame set reads every source
constexpr int64_t kFrameUs = 10'000;

// What one published frame set showed: the frames and camera 1's status right after its reads.
struct Published {
  std::shared_ptr<const CapturedFrameSet> frames;
  CameraStatus status1;
};

// Plays `sources` at kFps until `count` frame sets are published; returns every one published
// (at least `count`, in order).
std::vector<Published> play(std::vector<std::unique_ptr<FrameSource>> sources, size_t count,
                            SiteOptions options = {}) {
  SitePlayer player(std::move(sources), kFps, {}, options);
  std::mutex m;
  std::condition_variable cv;
  std::vector<Published> out;
  player.start([&](std::shared_ptr<const CapturedFrameSet> f) {
    const CameraStatus s = player.camera_status()[1];  // this thread did the reads: current
    std::lock_guard lock(m);
    out.push_back({std::move(f), s});
    cv.notify_all();
  });
  {
    std::unique_lock lock(m);
    const bool done =
        cv.wait_for(lock, std::chrono::seconds(120), [&] { return out.size() >= count; });
    EXPECT_TRUE(done) << "only " << out.size() << " frame sets published";
  }
  player.stop();
  return out;
}

// Camera 0: the real hands sequence. Camera 1: `dir`, a hands-derived folder.
std::vector<std::unique_ptr<FrameSource>> two_cameras(const fs::path& dir) {
  std::vector<std::unique_ptr<FrameSource>> v;
  v.push_back(open_source(test::hands_dir(), test::hands_options(kFps)));
  v.push_back(open_source(dir, test::hands_options(kFps)));
  return v;
}

// Camera 0 (good) advances in every frame set: its device time is (sequence - 1) frames.
void expect_good_camera_advances_every_time(const std::vector<Published>& sets) {
  for (size_t n = 0; n < sets.size(); ++n) {
    ASSERT_EQ(sets[n].frames->sequence, n + 1);
    EXPECT_EQ(sets[n].frames->cameras[0]->device_timestamp_us, static_cast<int64_t>(n) * kFrameUs)
        << "frame set " << n + 1;
  }
}

class CorruptFrame : public testing::TestWithParam<test::BadDepth> {};

TEST_P(CorruptFrame, IsSkippedWithOneWarningWhileTheOtherCameraGoesOn) {
  test::LogCapture log;
  constexpr int kFrames = 8, kBad = 4;
  const fs::path dir = test::hands_sequence(
      test::temp_dir(std::string("site_corrupt_") + test::name_of(GetParam())), kFrames, true);
  const fs::path bad = test::break_depth(dir, kBad, GetParam());
  const auto sets = play(two_cameras(dir), 3 * kFrames + 2);  // three passes over the bad frame

  expect_good_camera_advances_every_time(sets);
  const DepthImage after_bad = read_depth_png(test::hands_depth(kBad + 1));
  int repeats = 0;
  for (size_t n = 1; n < sets.size(); ++n) {
    const int frame = static_cast<int>(n % kFrames);  // camera 1's frame index in set n + 1
    const auto& cam = sets[n].frames->cameras[1];
    if (frame == kBad) {
      // The bad frame is skipped: the previous frame again, the very same one.
      EXPECT_EQ(cam, sets[n - 1].frames->cameras[1]) << "frame set " << n + 1;
      ++repeats;
    } else {
      EXPECT_EQ(cam->device_timestamp_us, static_cast<int64_t>(n) * kFrameUs)
          << "frame set " << n + 1;
      if (frame == kBad + 1) {
        EXPECT_EQ(cam->depth, after_bad);  // and then it goes on
      }
    }
  }
  EXPECT_GE(repeats, 3);
  EXPECT_FALSE(sets.back().status1.failed);
  EXPECT_EQ(sets.back().status1.read_failures, static_cast<uint64_t>(repeats));
  EXPECT_EQ(log.count(bad.string()), 1) << log.text();  // once, however often it loops
}

INSTANTIATE_TEST_SUITE_P(Kinds, CorruptFrame,
                         testing::Values(test::BadDepth::kTruncated, test::BadDepth::kEightBit,
                                         test::BadDepth::kOtherSize),
                         [](const auto& p) { return std::string(test::name_of(p.param)); });

TEST(SiteCapture, ConsecutiveBadFramesMarkOnlyThatCameraFailedUntilItReadsAgain) {
  test::LogCapture log;
  constexpr int kFrames = 10;
  const fs::path dir = test::hands_sequence(test::temp_dir("site_failed"), kFrames, true);
  for (int i : {3, 4, 5}) test::break_depth(dir, i, test::BadDepth::kTruncated);
  SiteOptions options;
  options.max_read_failures = 3;
  const auto sets = play(two_cameras(dir), 2 * kFrames + 1, options);

  expect_good_camera_advances_every_time(sets);  // never held up by camera 1
  int failures = 0, recoveries = 0;
  for (size_t n = 0; n < sets.size(); ++n) {
    const int frame = static_cast<int>(n % kFrames);
    // Failed exactly from the third bad frame in a row until the next good one.
    EXPECT_EQ(sets[n].status1.failed, frame == 5) << "frame set " << n + 1;
    if (n > 0) {
      failures += sets[n].status1.failed && !sets[n - 1].status1.failed;
      recoveries += !sets[n].status1.failed && sets[n - 1].status1.failed;
    }
    // Through the bad run camera 1 repeats frame 2; every frame set has both cameras.
    ASSERT_EQ(sets[n].frames->cameras.size(), 2u);
    if (frame >= 3 && frame <= 5) {
      EXPECT_EQ(sets[n].frames->cameras[1]->device_timestamp_us,
                static_cast<int64_t>(n - static_cast<size_t>(frame - 2)) * kFrameUs);
    }
  }
  EXPECT_GE(failures, 2);
  // Logged once per time it failed and once per recovery; each bad file named once.
  EXPECT_EQ(log.count("FAILED"), failures) << log.text();
  EXPECT_EQ(log.count("recovered"), recoveries) << log.text();
  for (int i : {3, 4, 5})
    EXPECT_EQ(log.count((dir / "depth" / test::hands_depth(i).filename()).string()), 1);
}

// A consumer that, like a tier encoder, holds only the newest frame sets: the site recycles the
// frames no frame set holds any more (no allocation per frame), and never one still held.
TEST(SiteCapture, FramesAreRecycledOnlyOnceNoFrameSetHoldsThem) {
  std::vector<std::unique_ptr<FrameSource>> sources;
  sources.push_back(open_source(test::hands_dir(), test::hands_options(kFps)));
  SourceOptions kinect;
  kinect.fps = kFps;
  sources.push_back(open_source(test::kinect_mkv(), kinect));
  std::vector<std::unique_ptr<FrameSource>> reference;  // the same sources, read directly
  reference.push_back(open_source(test::hands_dir(), test::hands_options(kFps)));
  reference.push_back(open_source(test::kinect_mkv(), kinect));
  std::vector<CameraFrame> expected;
  constexpr size_t kSets = 60;
  for (size_t n = 0; n < kSets; ++n)
    for (auto& r : reference) expected.push_back(r->next());

  SitePlayer player(std::move(sources), kFps);
  std::mutex m;
  std::condition_variable cv;
  std::deque<std::shared_ptr<const CapturedFrameSet>> held;  // the newest two
  std::set<const CameraFrame*> addresses[2];
  size_t seen = 0;
  player.start([&](std::shared_ptr<const CapturedFrameSet> f) {
    std::lock_guard lock(m);
    if (seen >= kSets) return;
    // Every frame set still held shows what it showed when it was published.
    for (const auto& h : held)
      for (size_t i = 0; i < 2; ++i) {
        const CameraFrame& want = expected[2 * (h->sequence - 1) + i];
        EXPECT_EQ(h->cameras[i]->device_timestamp_us, want.device_timestamp_us);
        EXPECT_EQ(h->cameras[i]->depth, want.depth) << "frame set " << h->sequence;
      }
    for (size_t i = 0; i < 2; ++i) addresses[i].insert(f->cameras[i].get());
    held.push_back(std::move(f));
    if (held.size() > 2) held.pop_front();
    ++seen;
    cv.notify_all();
  });
  {
    std::unique_lock lock(m);
    EXPECT_TRUE(cv.wait_for(lock, std::chrono::seconds(120), [&] { return seen >= kSets; }));
  }
  player.stop();
  std::lock_guard lock(m);
  for (size_t n = 0; n < held.size(); ++n) EXPECT_EQ(held[n]->sequence, kSets - 1 + n);
  for (const auto& h : held)
    for (size_t i = 0; i < 2; ++i) {
      const CameraFrame& want = expected[2 * (h->sequence - 1) + i];
      EXPECT_EQ(h->cameras[i]->depth, want.depth);
      EXPECT_EQ(h->cameras[i]->color, want.color);
    }
  // Two held, one being read, one just released: a handful of buffers for 60 frame sets.
  EXPECT_LE(addresses[0].size(), 5u);
  EXPECT_LE(addresses[1].size(), 5u);
}

// Pacing, on a clock the test steps (exact counts whatever the load): a 30 fps and a 5 fps camera
// in a 30 fps site. The 5 fps camera's frame k is read at the tick nearest k * 200 ms (frame sets
// 6k + 1 .. 6k + 6 show it). After a 1 s stall (in frame set 10's tick) the site skips the ticks it
// missed without making up for them: each camera reads one frame (the 5 fps one does not catch up
// on the four more that fell due), frame sets stay numbered without gaps, and the 5 fps camera's
// next frame is 200 ms after its read.
TEST(SiteCapture, EachCameraIsReadAtTheTickNearestItsFrameAndAStallIsNotMadeUp) {
  auto sources_at = [](double fps0, double fps1) {
    std::vector<std::unique_ptr<FrameSource>> v;
    v.push_back(open_source(test::hands_dir(), test::hands_options(fps0)));
    v.push_back(open_source(test::hands_dir(), test::hands_options(fps1)));
    return v;
  };
  std::vector<int64_t> stamps[2];  // each camera's own frames, read directly
  {
    auto reference = sources_at(30, 5);
    for (int k = 0; k < 24; ++k) stamps[0].push_back(reference[0]->next().device_timestamp_us);
    for (int k = 0; k < 5; ++k) stamps[1].push_back(reference[1]->next().device_timestamp_us);
  }
  test::SteppedClock clock;
  SitePlayer player(sources_at(30, 5), 30, {}, clock.options());
  const test::ReleaseOnExit release{clock};
  std::mutex m;
  std::condition_variable cv;
  std::vector<std::shared_ptr<const CapturedFrameSet>> sets;
  player.start([&](std::shared_ptr<const CapturedFrameSet> f) {
    if (f->sequence == 10) clock.advance(1'000'000);  // frame set 10's tick takes 1 s
    std::lock_guard lock(m);
    sets.push_back(std::move(f));
    cv.notify_all();
  });
  clock.allow(24);
  {
    std::unique_lock lock(m);
    EXPECT_TRUE(cv.wait_for(lock, std::chrono::seconds(120), [&] { return sets.size() >= 24; }));
  }
  clock.release();
  player.stop();
  ASSERT_GE(sets.size(), 24u);
  for (size_t n = 1; n <= 24; ++n) {
    const CapturedFrameSet& f = *sets[n - 1];
    ASSERT_EQ(f.sequence, n);
    // The 30 fps camera: one frame per tick, before and after the stall.
    EXPECT_EQ(f.cameras[0]->device_timestamp_us, stamps[0][n - 1]) << "frame set " << n;
    // The 5 fps camera: frame 0 in sets 1-6, frame 1 from set 7 until the stall; then frame 2
    // (one read) in sets 11-16, frame 3 in 17-22, frame 4 from 23 on.
    const size_t k = n <= 6 ? 0 : n <= 10 ? 1 : 2 + (n - 11) / 6;
    EXPECT_EQ(f.cameras[1]->device_timestamp_us, stamps[1][k]) << "frame set " << n;
  }
}

TEST(SiteCapture, ACameraWithoutAGoodFrameYetSendsAnEmptyFrame) {
  const fs::path dir = test::hands_sequence(test::temp_dir("site_first_bad"), 4, true);
  test::break_depth(dir, 0, test::BadDepth::kEightBit);
  const auto sets = play(two_cameras(dir), 3);
  const CameraFrame& first = *sets[0].frames->cameras[1];
  EXPECT_EQ(first.depth, DepthImage(640, 360));  // the calibrated size, all invalid
  EXPECT_TRUE(first.color.empty());
  EXPECT_EQ(sets[1].frames->cameras[1]->depth, read_depth_png(test::hands_depth(1)));
}

TEST(SiteCapture, InfoChecksEveryFrameAndNamesTheBadOnes) {
  const fs::path dir = test::hands_sequence(test::temp_dir("info_bad"), 12, true, {7});
  const fs::path bad = test::break_depth(dir, 5, test::BadDepth::kTruncated);
  std::string out;
  const fs::path json = dir / "info.json";  // stdout alone: logs go to stderr
  ASSERT_EQ(test::run_command("(" + std::string(test::paths::volcast()) + " info --json " +
                                  dir.string() + " >" + json.string() + ")",
                              out),
            0)
      << out;
  std::ifstream in(json);
  const auto j = nlohmann::json::parse(in);
  EXPECT_EQ(j["checked_frames"], 12);
  EXPECT_EQ(j["frames_without_color"], 1);
  ASSERT_EQ(j["bad_frame_count"], 1);
  EXPECT_EQ(j["bad_frames"][0]["index"], 5);
  const std::string error = j["bad_frames"][0]["error"];
  EXPECT_NE(error.find(bad.string()), std::string::npos) << error;
  EXPECT_NE(error.find("truncated PNG"), std::string::npos) << error;

  // The text names it too, and a file claiming a huge size costs nothing to check.
  const fs::path huge = dir / "depth" / test::hands_depth(9).filename();
  fs::remove(huge);
  test::write_png_header_claiming(huge, 20000, 20000);
  ASSERT_EQ(test::run_command(std::string(test::paths::volcast()) + " info " + dir.string(), out),
            0)
      << out;
  EXPECT_NE(out.find("2 cannot be read"), std::string::npos) << out;
  EXPECT_NE(out.find(bad.string()), std::string::npos) << out;
  EXPECT_NE(out.find(huge.string() + "' claims 20000x20000"), std::string::npos) << out;
}

}  // namespace
}  // namespace volcast
