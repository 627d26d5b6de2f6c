// Rate adaptation over impaired paths (root: network namespaces; they skip with the reason
// otherwise): the real hands sequence streamed to viewers behind the userspace relay, whose
// bottleneck is narrowed and widened while they watch. Behaviour only -- which tiers, in which
// order, what each viewer decoded; the figures come from the benchmark.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <mutex>
#include <thread>

#include "support/hands_site.hpp"
#include "volcast/bench/impaired_link.hpp"
#include "volcast/net/stream/client.hpp"
#include "volcast/pipeline/sender.hpp"
#include "volcast/pipeline/stage_stats.hpp"

namespace volcast {
namespace {

using Clock = std::chrono::steady_clock;

// The hands site served in the link's server namespace.
struct LinkSite {
  SitePlayer player;
  std::unique_ptr<Server> server;
  LinkSite(ImpairedLink& link, ServerConfig config, double fps)
      : player(test::HandsSite::sources(), fps) {
    config.bind_address = link.server_address();
    config.port = 0;
    config.tier_cpu_budget = 16;  // every rung fits: the budget is not what is tested here
    config.max_tiers_per_address = 8;
    server = link.in_server_namespace(
        [&] { return std::make_unique<Server>(player.cameras(), config); });
    player.start(*server);
  }
  ~LinkSite() {
    player.stop();
    server->stop();
  }
  // The report of viewer `id` (1, 2, ... in the order they connected).
  ViewerReport viewer(uint64_t id) const {
    for (const auto& v : server->viewers())
      if (v.id == id) return v;
    return {};
  }
  double tier_mbit_s(const std::string& depth, const std::string& color) const {
    for (const auto& t : server->tiers())
      if (t.tier.depth_codec == depth && t.tier.color_codec == color) return t.mbit_s;
    return 0;
  }
  uint64_t tier_frames(const std::string& depth, const std::string& color) const {
    for (const auto& t : server->tiers())
      if (t.tier.depth_codec == depth && t.tier.color_codec == color) return t.frames_encoded;
    return 0;
  }
};

// A viewer receiving on its own thread, keeping what it got.
struct Watcher {
  struct Got {
    Clock::time_point at;
    std::string tier;  // depth/color of the frame set
    bool lossless = true;
    double latency_ms = 0;  // capture -> received
    bool exact = true;      // decoded depth equals the source (when checked)
  };
  std::unique_ptr<Client> client;
  std::thread thread;
  std::atomic<bool> stop{false};
  mutable std::mutex mutex;
  std::vector<Got> got;
  TierState tier;
  std::string error;

  Watcher(std::unique_ptr<Client> c, bool check_depth) : client(std::move(c)) {
    thread = std::thread([this, check_depth] {
      ReceivedFrameSet rx;
      try {
        while (!stop && client->receive(rx)) {
          Got g{Clock::now(),
                client->tier().tier.depth_codec + "/" + client->tier().tier.color_codec,
                client->tier().lossless_depth,
                double(rx.times.received_us - rx.times.capture_us) / 1000, true};
          if (check_depth)
            g.exact = rx.frames.cameras[0].depth == test::hands_source_frame(rx.frames.sequence);
          std::lock_guard lock(mutex);
          got.push_back(g);
          tier = client->tier();
        }
      } catch (const std::exception& e) {
        std::lock_guard lock(mutex);
        error = e.what();
      }
    });
  }
  ~Watcher() {
    stop = true;
    client->close();
    thread.join();
  }
  TierState now() const {
    std::lock_guard lock(mutex);
    return tier;
  }
};

// Waits (polling every 50 ms) until `done` or `seconds` pass; returns `done()`.
template <class F>
bool wait_for(F done, double seconds) {
  const auto end = Clock::now() + std::chrono::duration<double>(seconds);
  while (!done() && Clock::now() < end) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  return done();
}

ClientConfig viewer_config(const Server& server, const std::string& host) {
  ClientConfig c = client_config_from_link(server.join_link(host));
  c.tier.depth_codec = "zstd";
  c.tier.color_codec = "jpeg";
  c.tier.color_quality = 90;
  return c;
}

const std::vector<std::string> kLadder = {"zstd/jpeg/90", "volcast/jpeg/40",
                                          "volcast-n4/jpeg/20@2"};

TEST(Adaptation, AViewerStepsDownWhenItsPathShrinksAndBackUpWhenItRecoversWhileAnotherStaysOnTop) {
  std::string why;
  auto link = ImpairedLink::create(LinkImpairment{}, &why);
  if (!link) GTEST_SKIP() << why;
  ServerConfig config;
  config.ladder = kLadder;
  config.rate_control.hold_us = 2'500'000;
  config.rate_control.probe_us = 1'500'000;
  config.rate_control.max_hold_us = 5'000'000;
  LinkSite site(*link, config, 15);
  ClientConfig c = viewer_config(*site.server, link->server_address());
  c.adapt = true;
  c.decode = false;  // the path is what is measured, not this machine's decoding
  // One viewer beside the server (its loopback: no bottleneck), one across the link.
  Watcher near(link->in_server_namespace([&] { return std::make_unique<Client>(c); }), false);
  Watcher far(link->in_client_namespace([&] { return std::make_unique<Client>(c); }), false);
  ASSERT_TRUE(wait_for([&] { return site.tier_frames("zstd", "jpeg") >= 30; }, 60));
  EXPECT_EQ(site.viewer(2).rung, 0) << "an unlimited path keeps the best rung";
  const double top = site.tier_mbit_s("zstd", "jpeg");

  // The bottleneck narrows to 40 % of the best rung's rate, and stays at 40 % of it (set again
  // every 200 ms from the server's figure over the last second) until the path recovers: a rate
  // is bytes per frame set times frame sets per second, and how many frame sets a second the site
  // makes depends on how busy this machine is. A path sized once from the rate measured early
  // (4.2 Mbit/s while the site made 5 frame sets a second beside other tests' start-ups) was
  // narrower than even the lightest rung's 2.6 Mbit/s once the site reached 15, and its queue
  // never drained (far p50 307 ms, near 35). Tracking the site's rate keeps the lightest rung
  // (about a fifth of the best) under the path whatever the site's speed.
  std::atomic<double> path_mbit_s = 0.4 * top;
  link->set_impairment({.rate_bits_per_s = path_mbit_s * 1e6}, {});
  std::atomic<bool> track{true};
  std::thread tracker([&] {
    while (track) {
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
      const double best = site.tier_mbit_s("zstd", "jpeg");
      if (!track || best <= 0) continue;
      path_mbit_s = 0.4 * best;
      link->set_impairment({.rate_bits_per_s = path_mbit_s * 1e6}, {});
    }
  });
  struct Join {
    std::atomic<bool>& track;
    std::thread& thread;
    ~Join() {
      track = false;
      if (thread.joinable()) thread.join();
    }
  } join{track, tracker};
  ASSERT_TRUE(wait_for([&] { return site.viewer(2).rung > 0; }, 10))
      << "the far viewer stepped down (best rung " << top << " Mbit/s, path " << path_mbit_s.load()
      << ")";
  const ViewerReport stepped = site.viewer(2);
  ASSERT_FALSE(stepped.switches.empty());
  std::printf("best rung %.1f Mbit/s, path %.1f Mbit/s: %s -> %s: %s\n", top, path_mbit_s.load(),
              stepped.switches.back().from.c_str(), stepped.switches.back().to.c_str(),
              stepped.switches.back().reason.c_str());
  EXPECT_EQ(site.viewer(1).rung, 0) << "the viewer beside the server stays on the best rung";
  // Two viewers on two paths: two tiers, each encoded once for its viewer (CPU counted per tier).
  const auto tiers = site.server->tiers();
  for (const auto& t : tiers) {
    std::printf("tier %s/%s/%d@%d: %d viewers, %llu frame sets, %.2f ms CPU each, %.1f Mbit/s\n",
                t.tier.depth_codec.c_str(), t.tier.color_codec.c_str(), t.tier.color_quality,
                t.tier.frame_divisor, t.viewers, static_cast<unsigned long long>(t.frames_encoded),
                t.cpu_ms_mean, t.mbit_s);
    EXPECT_LE(t.viewers, 1);
    if (t.frames_encoded > 2) {
      EXPECT_GT(t.cpu_ms_mean, 0);
    }
  }
  EXPECT_GE(tiers.size(), 2u);
  EXPECT_LE(tiers.size(), kLadder.size());

  // On the lighter tier the path's queue drains: over a window of the next 8 frame sets each
  // viewer receives, the far viewer's latency is back within the server's budget (150 ms) of the
  // near one's, whose path has no bottleneck. Relative, and counted in frame sets rather than
  // seconds: on a loaded machine both include its slower encoding, the old tier's queue takes
  // longer to drain (423 ms p50 once, 0.6 s after the step), and the site may make only a few
  // frame sets a second (under stress-ng, fewer than 3 reached the far viewer in a 1 s window).
  constexpr size_t kWindow = 8;
  const auto received = [](const Watcher& w) {
    std::lock_guard lock(w.mutex);
    return w.got.size();
  };
  const auto window_p50 = [](const Watcher& w, size_t from) {
    std::vector<double> latency;
    std::lock_guard lock(w.mutex);
    for (size_t i = from; i < w.got.size() && latency.size() < kWindow; ++i)
      latency.push_back(w.got[i].latency_ms);
    return percentile(latency, 0.5);
  };
  double far_p50 = 0, near_p50 = 0;
  int windows = 0;
  for (bool drained = false; !drained && windows < 20; ++windows) {
    const size_t far_from = received(far), near_from = received(near);
    ASSERT_TRUE(wait_for(
        [&] {
          return received(far) >= far_from + kWindow && received(near) >= near_from + kWindow;
        },
        60))
        << "both viewers receive " << kWindow << " more frame sets (far "
        << received(far) - far_from << ", near " << received(near) - near_from << ")";
    far_p50 = window_p50(far, far_from);
    near_p50 = window_p50(near, near_from);
    drained = far_p50 < near_p50 + 150.0;
  }
  EXPECT_LT(far_p50, near_p50 + 150.0)
      << "in each of " << windows << " windows of " << kWindow
      << " frame sets the far viewer's latency p50 stayed over the near one's + 150 ms; last: far "
      << far_p50 << " ms, near " << near_p50 << " ms";
  std::printf("on the lighter tier: latency p50 far %.1f ms, near %.1f ms\n", far_p50, near_p50);

  // The path recovers: probes bring the far viewer back to the best rung.
  track = false;
  tracker.join();
  link->set_impairment({}, {});
  EXPECT_TRUE(wait_for([&] { return site.viewer(2).rung == 0; }, 20))
      << "back on the best rung; now on " << site.viewer(2).rung;
  // The viewer's own view of it follows with the next frame set after the change.
  EXPECT_TRUE(wait_for([&] { return far.now().tier.depth_codec == "zstd"; }, 10))
      << "the far viewer decodes the best rung again; it is on " << far.now().tier.depth_codec;
  const TierState t = far.now();
  EXPECT_GE(t.changes, 2u) << "the viewer took each change";
  EXPECT_TRUE(far.error.empty()) << far.error;
  EXPECT_TRUE(near.error.empty()) << near.error;
}

TEST(Adaptation, APinnedOrLosslessFloorViewerIsNeverGivenLossyDepthButIsToldWhy) {
  std::string why;
  auto link = ImpairedLink::create(LinkImpairment{}, &why);
  if (!link) GTEST_SKIP() << why;
  ServerConfig config;
  config.ladder = kLadder;  // rung 2 has lossy depth (volcast-n4)
  config.rate_control.hold_us = 1'500'000;
  LinkSite site(*link, config, 10);
  ClientConfig pinned = viewer_config(*site.server, link->server_address());  // notify, no adapt
  ClientConfig floor = pinned;
  floor.adapt = true;
  floor.keep_lossless = true;
  {
    Watcher a(link->in_client_namespace([&] { return std::make_unique<Client>(pinned); }), true);
    ASSERT_TRUE(wait_for([&] { return site.tier_mbit_s("zstd", "jpeg") > 0; }, 10));
    std::this_thread::sleep_for(std::chrono::milliseconds(1500));
    const double top = site.tier_mbit_s("zstd", "jpeg");
    link->set_impairment({.rate_bits_per_s = 0.2 * top * 1e6}, {});
    EXPECT_TRUE(wait_for([&] { return a.now().notices > 0; }, 15)) << "the pinned viewer was told";
    std::lock_guard lock(a.mutex);
    EXPECT_TRUE(a.error.empty()) << a.error;
    EXPECT_EQ(a.tier.changes, 0u) << "a pinned tier is never changed";
    EXPECT_FALSE(a.tier.reason.empty());
    std::printf("pinned viewer told: %s\n", a.tier.reason.c_str());
    ASSERT_FALSE(a.got.empty());
    for (const auto& g : a.got) {
      EXPECT_EQ(g.tier, "zstd/jpeg");
      EXPECT_TRUE(g.exact);
    }
  }
  // Alone on the same narrow path, a viewer that adapts but keeps depth lossless: down to the
  // lightest lossless rung (volcast/jpeg/40), never the lossy one below it, and told.
  Watcher b(link->in_client_namespace([&] { return std::make_unique<Client>(floor); }), true);
  EXPECT_TRUE(wait_for([&] { return b.now().notices > 0; }, 20))
      << "the lossless-floor viewer was told its path cannot carry even its lightest tier";
  std::lock_guard lock(b.mutex);
  EXPECT_TRUE(b.error.empty()) << b.error;
  EXPECT_TRUE(b.tier.tier.depth_codec == "volcast" || b.tier.tier.depth_codec == "zstd")
      << b.tier.tier.depth_codec;
  std::printf("lossless-floor viewer told: %s\n", b.tier.reason.c_str());
  for (const auto& g : b.got) {
    EXPECT_TRUE(g.lossless) << g.tier;
    EXPECT_TRUE(g.exact) << "depth decoded exactly on " << g.tier;
  }
}

TEST(Adaptation, AnAdaptiveViewerAskingForATierOffTheLadderGetsTheLaddersBest) {
  // A hostile or confused viewer names a tier off the ladder and asks to adapt: it is served from
  // the ladder, and the server encodes nothing else.
  ServerConfig config;
  config.ladder = kLadder;
  test::HandsSite site(15, config);
  ClientConfig c = client_config_from_link(site.server.join_link("127.0.0.1"));
  c.tier.depth_codec = "volcast-t";
  c.tier.color_codec = "raw";
  c.tier.color_quality = 7;
  c.adapt = true;
  c.decode = false;
  Client client(c);
  ReceivedFrameSet rx;
  ASSERT_TRUE(client.receive(rx));
  EXPECT_EQ(client.tier().tier.depth_codec, "zstd");
  EXPECT_EQ(client.tier().tier.color_quality, 90);
  for (const auto& t : site.server.tiers()) EXPECT_EQ(t.tier.depth_codec, "zstd");
  // Without adapting, the same Hello is a tier of its own (the budget and offer decide).
  c.adapt = false;
  c.tier.depth_codec = "volcast";
  c.tier.color_codec = "jpeg";
  c.tier.color_quality = 0;
  Client pinned(c);
  ASSERT_TRUE(pinned.receive(rx));
  EXPECT_EQ(pinned.tier().tier.depth_codec, "volcast");
  EXPECT_EQ(pinned.tier().changes, 0u);
}

}  // namespace
}  // namespace volcast
