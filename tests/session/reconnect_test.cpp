// A viewer whose path is cut: the real hands site served with a session, a participant's viewer
// (run_viewer, as `volcast view --join`) behind a proxy that cuts its path -- its connection
// silent both ways, still open, as a cut path is before any timeout, and new ones refused until
// the path comes back. Behaviour only: what the viewer shows
// meanwhile, that it comes back by itself as the same participant, and what it draws after.
#include <gtest/gtest.h>

#include <atomic>
#include <mutex>
#include <thread>

#include "support/session_site.hpp"
#include "support/stalling_proxy.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/pipeline/headless_participant.hpp"
#include "volcast/pipeline/receiver.hpp"
#include "volcast/pipeline/session_client.hpp"

namespace volcast {
namespace {

using test::eventually;
using test::named;

// A presenter that draws nothing and keeps what it was handed: how many frame sets, and every
// state of the connection the panel would have shown.
struct Watch {
  std::mutex mutex;
  std::vector<std::string> connection;  // distinct states in order ("" = connected)
  std::atomic<uint64_t> frames{0};

  Presenter presenter() {
    return [this](FrameFeed& feed, ViewerResult& result) {
      std::vector<std::shared_ptr<const CameraFrame>> frames_now;
      while (!feed.finished()) {
        if (feed.next(frames_now, std::chrono::milliseconds(20))) {
          ++frames;
          ++result.frames_rendered;
        }
        const std::string c = feed.live().connection;
        std::lock_guard lock(mutex);
        if (connection.empty() || connection.back() != c) connection.push_back(c);
      }
    };
  }
  bool saw(const std::string& prefix) {
    std::lock_guard lock(mutex);
    for (const auto& c : connection)
      if (c.starts_with(prefix)) return true;
    return false;
  }
};

TEST(Reconnect, AViewerWhosePathStallsShowsReconnectingThenRejoinsAsItselfAndGoesOn) {
  SessionHubConfig hub;
  hub.presence_timeout_ms = 20000;  // the hub still holds it when it comes back (a short cut)
  test::SessionSite s(hub);
  test::StallingProxy proxy(s.site.server.port());
  test::TestParticipant b(s, named("Dr. B"));
  SessionClient a(named("Dr. A"));
  Watch watch;
  std::atomic<bool> stop{false};
  ViewerOptions opt;
  opt.client = client_config_from_link(s.link());
  opt.client.port = proxy.port();
  opt.client.receive_timeout_ms = 1500;  // a silence this long is a cut
  opt.reconnect = true;
  opt.stale_ms = 1000;
  opt.presenter = watch.presenter();
  opt.stop = &stop;
  int joined = 0, left = 0;  // the one participant lifecycle (the window's, the demo's)
  live_in_viewer(
      a, opt,
      {"OR", [&](SessionClient&) { ++joined; }, [&](SessionClient&, ViewerResult&) { ++left; }});
  ViewerResult result;
  std::string error;
  std::thread viewer([&] {
    try {
      result = run_viewer(opt);
    } catch (const ViewerError& e) {
      result = e.result();
      error = e.what();
    }
  });
  const auto a_id = [&] {
    Participant* p = a.participant();
    return p && p->joined() ? p->snapshot(wall_clock_us()).id : 0u;
  };
  ASSERT_TRUE(eventually([&] { return a_id() != 0 && b.other("Dr. A") && watch.frames >= 5; }))
      << error;
  const uint32_t id = a_id();

  proxy.cut();  // the path goes silent both ways; the server still holds the connection
  EXPECT_TRUE(eventually([&] { return watch.saw("reconnecting"); })) << error;
  const uint64_t before = watch.frames;
  proxy.restore();  // the path comes back
  // It comes back by itself on a new connection, as the same participant, and draws again.
  EXPECT_TRUE(eventually([&] { return a_id() == id && watch.frames > before + 5; })) << error;
  EXPECT_EQ(proxy.accepted(), 2) << "the first connection, then the one after the cut";
  EXPECT_EQ(s.hub.stats().rejoins, 1u);
  EXPECT_TRUE(b.now().departed.empty()) << "Dr. B saw nobody leave";
  ASSERT_TRUE(b.other("Dr. A"));
  EXPECT_EQ(b.other("Dr. A")->id, id);
  EXPECT_EQ(s.hub.members("OR").size(), 3u);

  stop = true;
  viewer.join();
  EXPECT_EQ(joined, 1) << "joined once: the cut is a rejoin, not a second join";
  EXPECT_EQ(left, 1);
  EXPECT_EQ(result.session_name, "OR");
  EXPECT_EQ(result.ended, ViewerEnd::kInterrupted) << result.error;
  ASSERT_EQ(result.outages.size(), 1u);
  EXPECT_GT(result.outages[0].back_us, result.outages[0].lost_us);
  EXPECT_NE(result.outages[0].why.find("receive timeout"), std::string::npos)
      << result.outages[0].why;
  // Shown in order: connected, reconnecting, reconnected (waiting for the key frame set), then
  // connected again.
  std::lock_guard lock(watch.mutex);
  ASSERT_GE(watch.connection.size(), 3u);
  EXPECT_EQ(watch.connection.front(), "");
  EXPECT_TRUE(watch.connection[1].starts_with("reconnecting")) << watch.connection[1];
  EXPECT_EQ(watch.connection.back(), "");
}

// The benchmarks' participants (bench_session_site.hpp join_bench) live the same life: a cut
// path, and it comes back by itself as the same participant.
TEST(Reconnect, AHeadlessParticipantRejoinsAsItselfAfterACut) {
  SessionHubConfig hub;
  hub.presence_timeout_ms = 20000;  // the hub still holds it when it comes back
  test::SessionSite s(hub);
  test::StallingProxy proxy(s.site.server.port());
  ClientConfig c = s.client_config();
  c.port = proxy.port();
  c.receive_timeout_ms = 1500;  // a silence this long is a cut
  int joined = 0;
  ParticipantLife life{"OR", [&](SessionClient&) { ++joined; }, {}};
  HeadlessParticipant a(c, named("Dr. A"), life);
  ASSERT_TRUE(a.wait_joined(20000)) << a.error();
  const uint32_t id = a.participant().snapshot(wall_clock_us()).id;
  ASSERT_NE(id, 0u);

  proxy.cut();      // its connection stalls for good
  proxy.restore();  // new connections go through: it must notice the silence and connect again
  EXPECT_TRUE(eventually([&] { return s.hub.stats().rejoins == 1; })) << a.error();
  EXPECT_TRUE(eventually([&] { return a.participant().joined(); }));
  EXPECT_EQ(a.participant().snapshot(wall_clock_us()).id, id);
  EXPECT_EQ(proxy.accepted(), 2) << "the first connection, then the one after the cut";
  EXPECT_EQ(s.hub.members("OR").size(), 2u) << "the site and Dr. A, once";

  a.end();
  EXPECT_TRUE(a.error().empty()) << a.error();
  EXPECT_EQ(joined, 1) << "joined once: the cut is a rejoin, not a second join";
  EXPECT_EQ(a.result().ended, ViewerEnd::kInterrupted) << a.result().error;
  EXPECT_EQ(a.result().session_name, "OR");
  ASSERT_EQ(a.result().outages.size(), 1u);
  EXPECT_NE(a.result().outages[0].why.find("receive timeout"), std::string::npos)
      << a.result().outages[0].why;
}

}  // namespace
}  // namespace volcast
