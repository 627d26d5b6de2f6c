// Recordings of the encoded stream (volcast/record): the file survives being killed and a full
// disk, rejects corruption naming the offset, and replays bit-exact what the server sent.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstring>
#include <fstream>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <random>

#include "support/hands_site.hpp"
#include "support/test_data.hpp"
#include "support/test_paths.hpp"
#include "volcast/capture/k4a_recording.hpp"
#include "volcast/capture/real_sites.hpp"
#include "volcast/codec/depth_codec.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/net/stream/client.hpp"
#include "volcast/pipeline/export.hpp"
#include "volcast/pipeline/replay.hpp"
#include "volcast/record/decode.hpp"
#include "volcast/record/recorder.hpp"
#include "volcast/record/recording.hpp"

namespace volcast {
namespace {

namespace fs = std::filesystem;

// Synthetic (for exact behaviour only): a one-camera 8x4 site and frame-set bodies whose camera
// bytes encode their index, so a reader can tell each one apart.
RecordingStream tiny_stream() {
  RecordingStream s;
  s.tier.depth_codec = "raw";
  s.tier.color_codec = "none";
  s.started_us = 1;
  s.origin = "record_test";
  protocol::CameraInfo c;
  c.calibration.depth = Intrinsics{8, 4, 10, 10, 4, 2};
  c.description = "synthetic";
  s.welcome.cameras.push_back(c);
  return s;
}

std::vector<uint8_t> tiny_body(uint64_t k, size_t bytes = 300) {
  protocol::EncodedCamera cam;
  cam.device_timestamp_us = static_cast<int64_t>(k) * 33333;
  cam.depth.resize(bytes);
  for (size_t i = 0; i < bytes; ++i) cam.depth[i] = static_cast<uint8_t>(k * 31 + i);
  protocol::SenderTimes t;
  t.capture_us = 1'000'000 + static_cast<int64_t>(k) * 33333;
  std::vector<uint8_t> body;
  protocol::serialize_frame_set_body(k + 1, k % 10 == 0, t, std::span(&cam, 1), body);
  return body;
}

fs::path write_tiny(const fs::path& dir, size_t count) {
  const fs::path path = dir / "tiny.vcr";
  RecordingWriter w(path, tiny_stream());
  for (size_t k = 0; k < count; ++k) w.append(tiny_body(k));
  w.close();
  return path;
}

std::vector<uint8_t> file_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

void put_file(const fs::path& p, std::span<const uint8_t> bytes) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
}

TEST(Recording, WritesAndReadsBackEveryFrameSetByteForByteWithItsIndex) {
  const auto dir = test::temp_dir("record_roundtrip");
  const fs::path path = write_tiny(dir, 25);
  RecordingReader r(path);
  const RecordingInfo& info = r.info();
  EXPECT_TRUE(info.closed);
  EXPECT_FALSE(info.incomplete_tail_at);
  EXPECT_EQ(info.stream.tier.depth_codec, "raw");
  EXPECT_EQ(info.stream.origin, "record_test");
  ASSERT_EQ(info.stream.welcome.cameras.size(), 1u);
  EXPECT_EQ(info.stream.welcome.cameras[0].calibration.depth.width, 8);
  ASSERT_EQ(info.frame_sets.size(), 25u);
  EXPECT_EQ(info.duration_us(), 24 * 33333);
  std::vector<uint8_t> body;
  for (size_t k = 0; k < 25; ++k) {
    r.read(k, body);
    EXPECT_EQ(body, tiny_body(k)) << k;
    EXPECT_EQ(info.frame_sets[k].sequence, k + 1);
    EXPECT_EQ(info.frame_sets[k].key, k % 10 == 0);
  }
  EXPECT_NO_THROW(r.verify());
  // An existing file is never overwritten unless asked.
  EXPECT_NE(test::error_of([&] { RecordingWriter w(path, tiny_stream()); }).find("exists"),
            std::string::npos);
  EXPECT_NE(test::error_of([&] { RecordingReader x(dir / "missing.vcr"); }).find("missing.vcr"),
            std::string::npos);
}

TEST(Recording, ARecorderKilledAtRandomPointsLeavesAFileThatReplaysToItsLastCompleteFrameSet) {
  const auto dir = test::temp_dir("record_killed");
  std::mt19937 random(20261123);
  int with_tail = 0;
  for (int run = 0; run < 20; ++run) {
    const fs::path path = dir / ("killed-" + std::to_string(run) + ".vcr");
    int ready[2];
    ASSERT_EQ(pipe(ready), 0);
    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      // The recorder: frame sets of 1..200 KB as fast as it can, a sync every 5 ms.
      RecordingWriter w(path, tiny_stream(), {.sync_interval_ms = 5});
      const char c = 1;
      [[maybe_unused]] auto n = write(ready[1], &c, 1);
      for (uint64_t k = 0;; ++k) w.append(tiny_body(k, 1000 + (k * 7919) % 200000));
    }
    char c = 0;
    ASSERT_EQ(read(ready[0], &c, 1), 1);
    close(ready[0]);
    close(ready[1]);
    std::this_thread::sleep_for(std::chrono::microseconds(random() % 150000));
    kill(child, SIGKILL);
    int status = 0;
    waitpid(child, &status, 0);
    ASSERT_TRUE(WIFSIGNALED(status));
    // It opens, was not closed, and every frame set it lists reads back intact and in order.
    RecordingReader r(path);
    EXPECT_FALSE(r.info().closed);
    with_tail += r.info().incomplete_tail_at.has_value();
    std::vector<uint8_t> body;
    for (size_t k = 0; k < r.info().frame_sets.size(); ++k) {
      r.read(k, body);
      ASSERT_EQ(body, tiny_body(k, 1000 + (k * 7919) % 200000)) << path << " frame set " << k;
    }
  }
  // Kills land inside a write often enough that some files end in a partial frame set (the rest
  // stopped between writes); both kinds open.
  RecordProperty("files_with_incomplete_tail", with_tail);
}

TEST(Recording, ACutFileOpensUpToItsLastCompleteFrameSetAndACutHeaderIsRefusedNamingTheOffset) {
  const auto dir = test::temp_dir("record_cut");
  const std::vector<uint8_t> whole = file_bytes(write_tiny(dir, 6));
  RecordingReader full(dir / "tiny.vcr");
  std::vector<uint64_t> ends;  // where each frame set's record ends
  for (const auto& f : full.info().frame_sets) ends.push_back(f.offset + 16 + f.bytes);
  const uint64_t first = full.info().frame_sets[0].offset;
  const uint64_t index_end = whole.size() - 24;  // the End record is the last 24 bytes
  const fs::path cut = dir / "cut.vcr";
  for (size_t n = 0; n < whole.size(); n += 7) {
    put_file(cut, std::span(whole).first(n));
    const std::string error = test::error_of([&] { RecordingReader r(cut); });
    if (n < first) {  // the file header or the stream description is incomplete
      EXPECT_NE(error, "") << n;
      EXPECT_NE(error.find(n < 16 ? "not a Volcast recording" : "offset"), std::string::npos)
          << error;
      continue;
    }
    ASSERT_EQ(error, "") << n;
    RecordingReader r(cut);
    size_t complete = 0;
    while (complete < ends.size() && ends[complete] <= n) ++complete;
    EXPECT_EQ(r.info().frame_sets.size(), complete) << n;
    // The incomplete tail begins where the last whole record ends (a frame set, or the index
    // of a close that was cut short).
    uint64_t last_end = complete ? ends[complete - 1] : first;
    if (n >= index_end) last_end = index_end;
    const bool on_boundary = n == last_end;
    EXPECT_EQ(r.info().incomplete_tail_at.has_value(), !on_boundary) << n;
    if (!on_boundary) {
      EXPECT_EQ(*r.info().incomplete_tail_at, last_end) << n;
    }
    EXPECT_NO_THROW(r.verify()) << n;
  }
}

TEST(Recording, AFlippedBitIsRejectedWithTheOffsetOfWhatItBroke) {
  const auto dir = test::temp_dir("record_flip");
  const std::vector<uint8_t> whole = file_bytes(write_tiny(dir, 6));
  RecordingReader ok(dir / "tiny.vcr");
  const auto& sets = ok.info().frame_sets;
  const fs::path bad = dir / "bad.vcr";
  struct Case {
    size_t at;
    std::string expect;  // in the error, from open or from verify
  };
  const std::vector<Case> cases = {
      {3, "no VCRECORD magic at offset 0"},
      {13, "corrupt file header at offset 0"},
      {16 + 5, "corrupt stream description at offset 16"},
      {40, "corrupt stream description at offset 16"},
      {sets[2].offset + 16 + 50, "corrupt frame set 2 at offset " + std::to_string(sets[2].offset)},
      {sets[4].offset + 4, "frame set 4 at offset " + std::to_string(sets[4].offset)},
      {whole.size() - 30, "index"},
  };
  for (const Case& c : cases) {
    std::vector<uint8_t> b = whole;
    b[c.at] ^= 0x10;
    put_file(bad, b);
    const std::string error = test::error_of([&] {
      RecordingReader r(bad);
      r.verify();
    });
    EXPECT_NE(error.find(c.expect), std::string::npos) << "flip at " << c.at << ": " << error;
  }
  // Without the index (a recorder that was killed), a broken frame set in the middle is refused
  // when the file is opened, naming its offset.
  std::vector<uint8_t> b(whole.begin(), whole.begin() + static_cast<ptrdiff_t>(sets[5].offset));
  b[sets[1].offset + 16 + 9] ^= 0x01;
  put_file(bad, b);
  EXPECT_NE(test::error_of([&] {
              RecordingReader r(bad);
            }).find("corrupt frame set at offset " + std::to_string(sets[1].offset)),
            std::string::npos);
}

TEST(Recording, AFullDiskStopsTheRecordingWithAClearErrorAndKeepsWhatWasWritten) {
  const auto dir = test::temp_dir("record_full");
  const fs::path path = dir / "full.vcr";
  // The file-size limit stands in for a full disk (the same cut-short write, EFBIG for ENOSPC).
  rlimit old{};
  ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &old), 0);
  const auto old_handler = signal(SIGXFSZ, SIG_IGN);
  rlimit small = old;
  small.rlim_cur = 1'000'000;
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &small), 0);
  std::string error;
  uint64_t written = 0;
  {
    RecordingWriter w(path, tiny_stream());
    error = test::error_of([&] {
      for (uint64_t k = 0; k < 1000; ++k) w.append(tiny_body(k, 30000));
    });
    written = w.frame_sets();
    // Nothing more is taken after the error.
    EXPECT_NE(test::error_of([&] { w.append(tiny_body(written)); }), "");
  }
  setrlimit(RLIMIT_FSIZE, &old);
  signal(SIGXFSZ, old_handler);
  EXPECT_NE(error.find("disk full"), std::string::npos) << error;
  EXPECT_NE(error.find(std::to_string(written) + " frame sets"), std::string::npos) << error;
  EXPECT_NE(error.find("full.vcr"), std::string::npos) << error;
  ASSERT_GT(written, 20u);
  RecordingReader r(path);
  EXPECT_FALSE(r.info().incomplete_tail_at);  // cut back to the last complete frame set
  ASSERT_EQ(r.info().frame_sets.size(), written);
  std::vector<uint8_t> body;
  for (size_t k = 0; k < written; ++k) {
    r.read(k, body);
    ASSERT_EQ(body, tiny_body(k, 30000));
  }
}

// Real data from here on: a real site streamed by a server, recorded on two tiers.
struct RecordedSite {
  fs::path spatial, temporal;  // volcast/jpeg and volcast-t/jpeg
  // Each camera's depth by sequence, as the site published it.
  std::map<uint64_t, std::vector<DepthImage>> published;
  std::map<uint64_t, std::vector<uint8_t>> sent;  // volcast-t bodies by sequence, as sent
};

// Records `sources` until each tier has `frame_sets` frame sets.
RecordedSite record_site(const fs::path& dir, std::vector<std::unique_ptr<FrameSource>> sources,
                         uint64_t frame_sets, int key_frame_interval = 60) {
  RecordedSite out;
  out.spatial = dir / "site-volcast.vcr";
  out.temporal = dir / "site-volcast-t.vcr";
  std::mutex mutex;
  SitePlayer player(std::move(sources), 30);
  ServerConfig config;
  config.port = 0;
  config.insecure = true;
  config.key_frame_interval = key_frame_interval;
  Server server(player.cameras(), config);
  RecordingStream stream;
  stream.tier.depth_codec = "volcast";
  stream.tier.color_codec = "jpeg";
  stream.welcome = {player.cameras(), wall_clock_us()};
  BackgroundRecorder spatial(out.spatial, stream);
  stream.tier.depth_codec = "volcast-t";
  BackgroundRecorder temporal(out.temporal, stream);
  server.add_tier_tap({"volcast", "jpeg"}, [&](const TierFrameSet& f) { spatial.push(f); });
  server.add_tier_tap({"volcast-t", "jpeg"}, [&](const TierFrameSet& f) {
    temporal.push(f);
    std::lock_guard lock(mutex);
    out.sent[f.sequence].assign(f.body.begin(), f.body.end());
  });
  player.start([&](std::shared_ptr<const CapturedFrameSet> f) {
    {
      std::lock_guard lock(mutex);
      auto& depth = out.published[f->sequence];
      for (const auto& c : f->cameras) depth.push_back(c->depth);
    }
    server.publish(std::move(f));
  });
  EXPECT_TRUE(test::eventually(
      [&] {
        return spatial.stats().frame_sets >= frame_sets &&
               temporal.stats().frame_sets >= frame_sets;
      },
      std::chrono::seconds(120)));
  player.stop();
  server.stop();
  spatial.stop();
  temporal.stop();
  EXPECT_EQ(spatial.stats().error, "");
  EXPECT_EQ(temporal.stats().error, "");
  return out;
}

std::vector<std::unique_ptr<FrameSource>> hands_sources() {
  return test::HandsSite::sources();
}

// Camera 0's frame (depth and color) of each recorded frame set by its device timestamp (which
// replay keeps).
std::map<int64_t, CameraFrame> frames_by_device_time(const fs::path& path) {
  RecordingReader reader(path);
  RecordingDecoder decoder(reader);
  FrameSet f;
  std::map<int64_t, CameraFrame> out;
  for (size_t k = 0; k < reader.info().frame_sets.size(); ++k) {
    decoder.decode(k, f);
    out[f.cameras[0].device_timestamp_us] = f.cameras[0];
  }
  return out;
}

// A viewer of `path` replayed by a server, on tier depth/color.
struct ReplayViewer {
  ReplayPlayer replay;
  Server server;
  Client client;
  ReplayViewer(const fs::path& path, const std::string& depth, const std::string& color)
      : replay(path, {.loop = true}),
        server(replay.cameras(),
               [] {
                 ServerConfig c;
                 c.port = 0;
                 c.insecure = true;
                 return c;
               }()),
        client([&] {
          ClientConfig c;
          c.port = server.port();
          c.token = server.token();
          c.insecure = true;
          c.tier.depth_codec = depth;
          c.tier.color_codec = color;
          c.keep_encoded = true;
          return c;
        }()) {
    replay.start(server);
  }
  ~ReplayViewer() {
    replay.stop();
    server.stop();
  }
};

protocol::FrameSetView view_of(std::vector<uint8_t>& message, std::span<const uint8_t> body) {
  message.assign(8, 0);
  message.insert(message.end(), body.begin(), body.end());
  protocol::FrameSetView v;
  protocol::parse_frame_set(message, v);
  return v;
}

TEST(Recording, TwoSecondsOfTheDemoSiteRecordedOnTheServerDecodeBitExactToWhatWasSent) {
  const auto dir = test::temp_dir("record_server");
  // The demo's two real cameras (hands sequence, Azure Kinect recording) at 30 fps, 2 s: two
  // key frame sets (one every 30) and the deltas after each.
  const RecordedSite site = record_site(dir, two_camera_site(test::data_dir()), 60, 30);
  RecordingReader reader(site.temporal);
  const auto& sets = reader.info().frame_sets;
  ASSERT_GE(sets.size(), 60u);
  EXPECT_TRUE(reader.info().closed);
  EXPECT_TRUE(sets[0].key);  // a tap begins at a key frame set
  EXPECT_GE(std::ranges::count_if(sets, [](const auto& k) { return k.key; }), 2);
  EXPECT_EQ(reader.info().stream.tier.depth_codec, "volcast-t");
  EXPECT_GE(reader.info().duration_us(), 1'900'000);
  // Every recorded body is the one the tier sent, and every depth frame of both cameras decodes
  // to what was published (volcast-t is lossless), deltas included, in order and out of order.
  RecordingDecoder decoder(reader);
  FrameSet frames;
  std::vector<uint8_t> body;
  size_t deltas = 0;
  for (size_t k = 0; k < sets.size(); ++k) {
    reader.read(k, body);
    ASSERT_EQ(body, site.sent.at(sets[k].sequence)) << k;
    decoder.decode(k, frames);
    const auto& published = site.published.at(sets[k].sequence);
    ASSERT_EQ(frames.cameras.size(), 2u);
    for (size_t c = 0; c < 2; ++c)
      ASSERT_EQ(frames.cameras[c].depth.pixels, published[c].pixels) << k << " camera " << c;
    deltas += !sets[k].key;
  }
  EXPECT_GT(deltas, sets.size() / 2);
  for (size_t k : {sets.size() / 2, size_t{3}, sets.size() - 1}) {
    decoder.decode(k, frames);
    EXPECT_EQ(frames.cameras[0].depth.pixels, site.published.at(sets[k].sequence)[0].pixels) << k;
  }
}

TEST(Recording, AReplayPassesTheRecordedTierThroughByteForByteAndEncodesOtherTiersAfresh) {
  const auto dir = test::temp_dir("record_replay");
  const RecordedSite hands = record_site(dir, hands_sources(), 60);
  const auto expected = frames_by_device_time(hands.spatial);
  RecordingReader reader(hands.spatial);
  std::map<int64_t, std::pair<std::vector<uint8_t>, std::vector<uint8_t>>> streams;
  std::vector<uint8_t> body, message;
  for (size_t k = 0; k < reader.info().frame_sets.size(); ++k) {
    reader.read(k, body);
    const auto v = view_of(message, body);
    streams[v.cameras[0].device_timestamp_us] = {
        {v.cameras[0].depth.begin(), v.cameras[0].depth.end()},
        {v.cameras[0].color.begin(), v.cameras[0].color.end()}};
  }
  {  // --from --to --no-loop: the frame sets the replay's time line puts in that part, once, in
     // order. The part is a quarter of the recording, its ends picked on that time line: a loaded
     // machine paces the live site unevenly (22 s for these 2 s once), and a gap over
     // kMaxReplayGapUs is replayed one frame interval long, so capture times alone would pick
     // other frame sets (or none) than the replay plays.
    const auto& sets = reader.info().frame_sets;
    const PlaybackTimeline timeline = playback_timeline(sets);
    const double from_s = double(timeline.offset_us[sets.size() / 4] / 1000) / 1e3;
    const double to_s = double(timeline.offset_us[sets.size() / 2]) / 1e6;
    std::vector<size_t> in_range;
    for (size_t k = 0; k < sets.size(); ++k) {
      const double t = double(timeline.offset_us[k]) / 1e6;
      if (t >= from_s - 1e-6 && t <= to_s + 1e-6) in_range.push_back(k);
    }
    ASSERT_GE(in_range.size(), sets.size() / 4);
    ReplayPlayer part(hands.spatial, {.from_s = from_s, .to_s = to_s, .loop = false});
    std::vector<int64_t> times;
    std::mutex m;
    part.start([&](std::shared_ptr<const CapturedFrameSet> f) {
      std::lock_guard lock(m);
      times.push_back(f->cameras[0]->device_timestamp_us);
    });
    ASSERT_TRUE(test::eventually([&] { return part.finished(); }));
    part.stop();
    ASSERT_EQ(times.size(), in_range.size());
    for (size_t i = 0; i < times.size(); ++i) {
      reader.read(in_range[i], body);
      EXPECT_EQ(times[i], view_of(message, body).cameras[0].device_timestamp_us) << i;
    }
    EXPECT_NE(test::error_of([&] {
                ReplayPlayer none(hands.spatial, {.from_s = 50});
              }).find("no frame sets between"),
              std::string::npos);
  }
  {  // The recorded tier: the recorded depth and color bytes, every frame set.
    ReplayViewer viewer(hands.spatial, "volcast", "jpeg");
    ReceivedFrameSet f;
    for (int n = 0; n < 30; ++n) {
      ASSERT_TRUE(viewer.client.receive(f));
      const auto v = view_of(message, f.encoded_body);
      const auto& [depth, color] = streams.at(v.cameras[0].device_timestamp_us);
      ASSERT_TRUE(std::ranges::equal(depth, v.cameras[0].depth)) << n;
      ASSERT_TRUE(std::ranges::equal(color, v.cameras[0].color)) << n;
      ASSERT_EQ(f.frames.cameras[0].depth.pixels,
                expected.at(f.frames.cameras[0].device_timestamp_us).depth.pixels);
    }
  }
  {  // Another tier: decoded and encoded again, the same depth (both lossless).
    ReplayViewer viewer(hands.spatial, "rvl", "none");
    ReceivedFrameSet f;
    for (int n = 0; n < 30; ++n) {
      ASSERT_TRUE(viewer.client.receive(f));
      ASSERT_EQ(f.frames.cameras[0].depth.pixels,
                expected.at(f.frames.cameras[0].device_timestamp_us).depth.pixels);
    }
  }
  {  // A temporal recording: its deltas pass through after the viewer's first key frame set.
    const auto expected_t = frames_by_device_time(hands.temporal);
    ReplayViewer viewer(hands.temporal, "volcast-t", "jpeg");
    ReceivedFrameSet f;
    for (int n = 0; n < 40; ++n) {
      ASSERT_TRUE(viewer.client.receive(f));
      ASSERT_EQ(f.frames.cameras[0].depth.pixels,
                expected_t.at(f.frames.cameras[0].device_timestamp_us).depth.pixels);
    }
    EXPECT_EQ(viewer.client.frames_undecodable(), 0u);
  }
}

// A recording of the real hands sequence rewritten as a file that lies: valid CRCs, but its
// capture time jumps 11.6 days forward at frame set 5 and 40 ms back at frame set 9 (the frame
// set head's capture time is bytes 9..16 of the body, protocol.hpp 1.1).
TEST(Recording, ACaptureTimeThatJumpsIsReplayedAtTheFramePaceAndNamedByInfo) {
  const auto dir = test::temp_dir("record_lying_clock");
  const RecordedSite hands = record_site(dir, hands_sources(), 12);
  const fs::path lying = dir / "lying.vcr";
  std::vector<int64_t> recorded;  // the capture times as recorded (this machine's pace)
  {
    RecordingReader reader(hands.spatial);
    RecordingWriter w(lying, reader.info().stream, {.overwrite = true});
    std::vector<uint8_t> body;
    int64_t shift = 0;
    for (size_t k = 0; k < 12; ++k) {
      reader.read(k, body);
      int64_t capture_us = 0;
      std::memcpy(&capture_us, body.data() + 9, 8);
      recorded.push_back(capture_us);
      if (k == 5) shift += 1'000'000'000'000;                   // 11.6 days on
      if (k == 9) shift -= recorded[9] - recorded[8] + 40'000;  // then 40 ms back
      capture_us += shift;
      std::memcpy(body.data() + 9, &capture_us, 8);
      w.append(body);
    }
    w.close();
  }
  ReplayPlayer player(lying, {.loop = false});
  const PlaybackTimeline& t = player.timeline();
  EXPECT_EQ(t.clamped_gaps, 2u);
  EXPECT_EQ(t.first_clamped, 5u);
  EXPECT_GE(t.first_clamped_gap_us, 1'000'000'000'000);
  // Played as recorded but for the two gaps, each one frame interval.
  EXPECT_EQ(t.duration_us(), recorded[11] - recorded[0] - (recorded[5] - recorded[4]) -
                                 (recorded[9] - recorded[8]) + 2 * t.frame_interval_us);
  std::atomic<int> published{0};
  player.start([&](std::shared_ptr<const CapturedFrameSet>) { ++published; });
  EXPECT_TRUE(test::eventually([&] { return player.finished(); }, std::chrono::seconds(60)))
      << published << " frame sets published, then the replay stalled";
  player.stop();
  EXPECT_EQ(published, 12);

  std::string out;
  ASSERT_EQ(test::run_command(
                std::string(test::paths::volcast()) + " info --json " + lying.string(), out),
            0)
      << out;
  const auto j = nlohmann::json::parse(out.substr(out.find('{')));
  EXPECT_EQ(j["clamped_gaps"], 2);
  const std::string warning = j["warning"];
  EXPECT_NE(warning.find("jumps by 11.6 days between frame sets 4 and 5"), std::string::npos)
      << warning;
  EXPECT_NEAR(j["duration_s"].get<double>(), static_cast<double>(t.duration_us()) / 1e6, 1e-6);
}

// The 40-byte BITMAPINFOHEADER (CodecPrivate) of `file`'s track whose fourcc is `fourcc`.
std::string codec_private(const fs::path& file, const std::string& fourcc) {
  std::ifstream in(file, std::ios::binary);
  std::string head(16384, '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  const size_t at = head.find(fourcc);
  return at == std::string::npos || at < 16 ? "" : head.substr(at - 16, 40);
}

TEST(Recording, ExportedToMatroskaTheAzureKinectCameraReadsBackWithItsIntrinsicsAndDepth) {
  const auto dir = test::temp_dir("record_mkv");
  // The genuine Azure Kinect recording (NFOV unbinned, Brown-Conrady lens) served and recorded.
  std::vector<std::unique_ptr<FrameSource>> sources;
  sources.push_back(open_source(test::kinect_mkv()));
  const CameraCalibration original = sources[0]->calibration();
  const RecordedSite site = record_site(dir, std::move(sources), 20);
  ExportOptions o;
  o.mkv = dir / "kinect.mkv";
  const ExportReport r = export_recording(site.spatial, o);
  EXPECT_EQ(r.files, 1u);
  // k4arecorder's own layout: the DEPTH track's codec private data is byte for byte the genuine
  // recording's (V_MS/VFW/FOURCC, 640x576, 16 bits, b16g), and so are the K4A tags read below.
  const std::string genuine = codec_private(test::kinect_mkv(), "b16g");
  ASSERT_EQ(genuine.size(), 40u);
  EXPECT_EQ(codec_private(o.mkv, "b16g"), genuine);
  {
    std::ifstream in(o.mkv, std::ios::binary);
    std::string head(16384, '\0');
    in.read(head.data(), static_cast<std::streamsize>(head.size()));
    for (const char* s :
         {"V_MS/VFW/FOURCC", "K4A_DEPTH_TRACK", "K4A_DEPTH_MODE", "K4A_CALIBRATION_FILE",
          "K4A_START_OFFSET_NS", "K4A_CUSTOM_TRACK_COLOR_ON_DEPTH", "calibration.json"})
      EXPECT_NE(head.find(s), std::string::npos) << s;
  }
  // Read back as any Azure Kinect recording: the same lens model and the same depth.
  auto back = open_source(o.mkv);
  const Intrinsics& a = back->calibration().depth;
  const Intrinsics& b = original.depth;
  EXPECT_EQ(a.width, 640);
  EXPECT_EQ(a.height, 576);
  for (auto [x, y] : {std::pair{a.fx, b.fx},
                      {a.fy, b.fy},
                      {a.cx, b.cx},
                      {a.cy, b.cy},
                      {a.k1, b.k1},
                      {a.k6, b.k6},
                      {a.p1, b.p1},
                      {a.p2, b.p2}})
    EXPECT_NEAR(x, y, 1e-9);
  EXPECT_NEAR(back->fps(), 5, 0.01);  // the camera's own rate, not the site's 30
  const K4aRecordingInfo info = probe_k4a_recording(o.mkv);
  EXPECT_EQ(info.depth_mode, "NFOV_UNBINNED");
  EXPECT_EQ(info.color_mode, "COLOR_ON_DEPTH");
  // The camera runs at 5 fps in a 30 fps site, so frame sets repeat its captures (how often depends
  // on the machine's load): the file holds each distinct capture once, with its color.
  const auto expected = frames_by_device_time(site.spatial);
  EXPECT_GE(expected.size(), 2u);
  EXPECT_EQ(info.depth_frames, static_cast<int>(expected.size()));
  EXPECT_EQ(info.color_frames, info.depth_frames);
  // Every capture at its device time (K4A_START_OFFSET_NS + block time), depth bit-exact, color
  // the recorded JPEG's within one more JPEG pass.
  for (const auto& [t, want] : expected) {
    SCOPED_TRACE(t);
    CameraFrame got;
    back->next(got);
    EXPECT_EQ(got.device_timestamp_us, t);
    EXPECT_EQ(got.depth.pixels, want.depth.pixels);
    ASSERT_EQ(got.color.width, want.color.width);
    ASSERT_EQ(got.color.bgra.size(), want.color.bgra.size());
    double diff = 0;
    for (size_t i = 0; i < got.color.bgra.size(); ++i)
      diff += std::abs(int(got.color.bgra[i]) - int(want.color.bgra[i]));
    EXPECT_LT(diff / static_cast<double>(got.color.bgra.size()), 2.0);
  }
  // A camera that is no Azure Kinect depth mode is refused by name.
  fs::create_directories(dir / "hands");
  const RecordedSite hands = record_site(dir / "hands", hands_sources(), 3);
  o.mkv = dir / "hands.mkv";
  EXPECT_NE(test::error_of([&] {
              export_recording(hands.spatial, o);
            }).find("640x360, not an Azure Kinect depth mode"),
            std::string::npos);
  // A full disk is an error naming the file, not a silently short file.
  if (fs::exists("/dev/full")) {
    o.mkv = "/dev/full";
    EXPECT_NE(test::error_of([&] { export_recording(site.spatial, o); }).find("/dev/full"),
              std::string::npos);
  }
}

}  // namespace
}  // namespace volcast
