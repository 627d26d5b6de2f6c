// Cameras without color, streamed from a Server to a Client on loopback under every color codec:
// a depth-only folder, and a folder with one color file missing. The folders are symlinks to the
// real hands sequence (sequence_folder.hpp).
#include <gtest/gtest.h>

#include <future>
#include <set>

#include "support/sequence_folder.hpp"
#include "support/test_data.hpp"
#include "volcast/codec_video/video_codecs.hpp"
#include "volcast/net/stream/client.hpp"
#include "volcast/pipeline/sender.hpp"

namespace volcast {
namespace {
namespace fs = std::filesystem;

constexpr double kFps = 30;

class NoColorStream : public testing::TestWithParam<std::string> {
 protected:
  void SetUp() override { register_video_codecs(); }  // h264, as the CLI does
};

// A site of `sources` served on a free loopback port; stale frame sets are not dropped (a loaded
// test machine must not hide frames from the assertions).
struct Site {
  SitePlayer player;
  Server server;
  explicit Site(std::vector<std::unique_ptr<FrameSource>> sources)
      : player(std::move(sources), kFps), server(player.cameras(), config()) {
    player.start(server);
  }
  ~Site() {
    player.stop();
    server.stop();
  }
  static ServerConfig config() {
    ServerConfig c;
    c.port = 0;
    c.latency_budget_ms = 60'000;
    return c;
  }
};

// Receives frame sets until `enough` says so (or `limit` sets), calling `check` on each; fails
// instead of hanging if none comes for a minute.
void receive(Client& client, int limit, const std::function<bool(const ReceivedFrameSet&)>& check) {
  ReceivedFrameSet rx;
  for (int i = 0; i < limit; ++i) {
    auto got = std::async(std::launch::async, [&] { return client.receive(rx); });
    if (got.wait_for(std::chrono::seconds(60)) != std::future_status::ready) {
      client.close();
      got.wait();
      FAIL() << "no frame set within 60 s after " << i;
    }
    ASSERT_TRUE(got.get()) << "the server ended the session after " << i << " frame sets";
    if (check(rx)) return;
  }
  FAIL() << "not done after " << limit << " frame sets";
}

ClientConfig client_config(const Site& site, const std::string& color_codec) {
  ClientConfig c = client_config_from_link(site.server.join_link("127.0.0.1"));
  c.tier.depth_codec = "rvl";
  c.tier.color_codec = color_codec;
  return c;
}

TEST_P(NoColorStream, DepthOnlyFolderStreamsWithEmptyColorBesideACameraWithColor) {
  const fs::path dir = test::temp_dir("depth_only_" + GetParam());
  fs::create_directory_symlink(test::hands_dir() / "depth", dir / "depth");
  std::vector<std::unique_ptr<FrameSource>> sources;
  sources.push_back(open_source(dir, test::hands_options(kFps)));
  sources.push_back(open_source(test::hands_dir(), test::hands_options(kFps)));
  EXPECT_EQ(sources[0]->color_frame_count(), 0);
  Site site(std::move(sources));
  Client client(client_config(site, GetParam()));
  int frames = 0;
  receive(client, 100, [&](const ReceivedFrameSet& rx) {
    EXPECT_EQ(rx.color_bytes[0], 0u);  // zero-length color: none
    EXPECT_TRUE(rx.frames.cameras[0].color.empty());
    EXPECT_EQ(rx.frames.cameras[0].depth.width, 640);
    EXPECT_EQ(rx.frames.cameras[0].depth.height, 360);
    if (GetParam() != "none") {
      EXPECT_EQ(rx.frames.cameras[1].color.width, 640);
    }
    return ++frames == 15;
  });
  EXPECT_EQ(client.frames_undecodable(), 0u);
  // The server counts a frame set as sent once its write returns: maybe just after the client
  // read it.
  EXPECT_TRUE(test::eventually([&] {
    for (const auto& v : site.server.viewers())
      if (v.frames_sent < 15) return false;
    return true;
  }));
  for (const auto& v : site.server.viewers()) EXPECT_TRUE(v.connected) << v.error;
}

std::string codec_name(const testing::TestParamInfo<std::string>& p) {
  return p.param;
}

INSTANTIATE_TEST_SUITE_P(ColorCodecs, NoColorStream, testing::Values("jpeg", "h264", "raw", "none"),
                         codec_name);

class MissingColorFile : public NoColorStream {};

TEST_P(MissingColorFile, LeavesThatFrameWithoutColorAndTheNextOnesWithIt) {
  constexpr int kFrames = 12, kMissing = 5;
  const fs::path dir = test::hands_sequence(test::temp_dir("missing_color_" + GetParam()), kFrames,
                                            true, {kMissing});
  std::vector<std::unique_ptr<FrameSource>> sources;
  sources.push_back(open_source(dir, test::hands_options(kFps)));
  EXPECT_EQ(sources[0]->color_frame_count(), kFrames - 1);
  Site site(std::move(sources));
  Client client(client_config(site, GetParam()));
  int without = 0, after = 0;  // frames seen without color, frames seen after one (with color)
  receive(client, 10 * kFrames, [&](const ReceivedFrameSet& rx) {
    const auto& f = rx.frames.cameras[0];
    const int frame =
        static_cast<int>(std::llround(static_cast<double>(f.device_timestamp_us) * kFps / 1e6)) %
        kFrames;
    if (frame == kMissing) {
      EXPECT_EQ(rx.color_bytes[0], 0u);
      EXPECT_TRUE(f.color.empty());
      ++without;
    } else {
      EXPECT_EQ(f.color.width, 640) << "frame " << frame;
      EXPECT_GT(rx.color_bytes[0], 0u);
      after += without > 0;
    }
    return without >= 2 && after >= 3;
  });
  EXPECT_EQ(client.frames_undecodable(), 0u);  // color after the gap decodes
}

INSTANTIATE_TEST_SUITE_P(ColorCodecs, MissingColorFile, testing::Values("jpeg", "h264"),
                         codec_name);

// H.264 color codes deltas: a viewer that starts on a key frame set where a camera has no color
// must still decode that camera's color when it returns (its first color frame is a key frame).
TEST(ColorGap, AViewerJoiningWhileACameraHasNoColorDecodesItsColorWhenItReturns) {
  register_video_codecs();
  constexpr int kFrames = 60;  // color only in frames 0-2: a gap of 57 frames (1.9 s)
  std::set<int> no_color;
  for (int i = 3; i < kFrames; ++i) no_color.insert(i);
  const fs::path dir = test::hands_sequence(test::temp_dir("color_gap"), kFrames, true, no_color);
  std::vector<std::unique_ptr<FrameSource>> sources;
  sources.push_back(open_source(dir, test::hands_options(kFps)));
  Site site(std::move(sources));
  Client first(client_config(site, "h264"));
  bool had_color = false;  // the first viewer: until the encoder has coded color, then a gap
  receive(first, 4 * kFrames, [&](const ReceivedFrameSet& rx) {
    had_color = had_color || !rx.frames.cameras[0].color.empty();
    return had_color && rx.frames.cameras[0].color.empty();
  });
  Client joiner(client_config(site, "h264"));
  int colored = 0;
  receive(joiner, 4 * kFrames, [&](const ReceivedFrameSet& rx) {
    colored += !rx.frames.cameras[0].color.empty();
    return colored == 3;
  });
  EXPECT_EQ(joiner.frames_undecodable(), 0u);
}

}  // namespace
}  // namespace volcast
