// The demo's scripted participants (volcast/demo/participants.hpp) when their path is cut: the
// real hands site served with a session, Dr. Hands (a camera avatar from the real hands sequence)
// and Dr. Mesh joined through a proxy that cuts their path -- their connections silent both ways,
// still open, as a cut path is before any timeout. Behaviour only: each comes back by itself as
// the same participant, nobody sees them leave, and their scripts go on where the others see them.
#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "support/session_site.hpp"
#include "support/stalling_proxy.hpp"
#include "support/test_data.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/demo/participants.hpp"

namespace volcast {
namespace {

using test::eventually;

TEST(DemoParticipants, RejoinAsThemselvesAfterACutAndTheirScriptsGoOn) {
  SessionHubConfig hub;
  hub.presence_timeout_ms = 20000;  // the hub still holds them when they come back
  test::SessionSite s(hub);
  test::StallingProxy proxy(s.site.server.port());
  test::TestParticipant watcher(s, test::hand_driven("Dr. Watcher"));
  DemoArgs args;
  args.session_seconds = 600;  // ended by `stop`
  std::atomic<bool> stop{false};
  args.stop = &stop;
  // Without the spoken exchange; Dr. Mesh points at the room's origin (where it draws is the
  // demo's own test, Cli.DemoStreams...).
  auto people = demo::participants(args, test::data_dir(), test::temp_dir("demo_participants"),
                                   s.link(), nullptr, demo::DrawingSpot{});
  ASSERT_EQ(people.size(), 2u);
  for (auto& p : people) {
    p->opt.client.port = proxy.port();
    p->opt.client.receive_timeout_ms = 1500;  // a silence this long is a cut
  }
  std::vector<std::thread> viewers = demo::start(people);
  const auto id_of = [](const demo::Person& p) {
    const Participant* part = p.session->participant();
    return part && part->joined() ? part->snapshot(wall_clock_us()).id : 0u;
  };
  const std::string hands = "Dr. Hands (camera)", mesh = "Dr. Mesh";
  const auto seen = [&] {
    const auto h = watcher.other(hands), m = watcher.other(mesh);
    return h && m && h->has_pose && m->has_pose && h->avatar_sequence > 0;
  };
  ASSERT_TRUE(eventually([&] { return id_of(*people[0]) && id_of(*people[1]) && seen(); }))
      << people[0]->error << people[1]->error;
  const uint32_t ids[2] = {id_of(*people[0]), id_of(*people[1])};
  const size_t members = s.hub.members("OR").size();

  // What the watcher received from each so far: Dr. Hands' avatar frames, Dr. Mesh's poses.
  const auto received = [&](const std::string& name, bool avatar) -> uint64_t {
    for (const RemoteStats& o : watcher.p().stats().others)
      if (o.name == name) return avatar ? o.avatar_frames_received : o.poses_received;
    return 0;
  };
  proxy.cut();  // both paths go silent for good; new connections are refused until restore()
  const uint64_t avatar_before = received(hands, true), poses_before = received(mesh, false);
  proxy.restore();
  // Each notices the silence, connects again and rejoins as itself (its Joined, with its own id,
  // arrives); its script goes on: more than 10 more of Dr. Hands' avatar frames and of Dr. Mesh's
  // poses reach the watcher (counted, not their sequence numbers, which jump over the cut).
  EXPECT_TRUE(eventually([&] {
    return s.hub.stats().rejoins == 2 && id_of(*people[0]) == ids[0] &&
           id_of(*people[1]) == ids[1] && received(hands, true) > avatar_before + 10 &&
           received(mesh, false) > poses_before + 10;
  })) << people[0]->error
      << people[1]->error << " ids " << id_of(*people[0]) << ", " << id_of(*people[1]);
  EXPECT_EQ(watcher.other(hands)->id, ids[0]);
  EXPECT_EQ(watcher.other(mesh)->id, ids[1]);
  EXPECT_TRUE(watcher.now().departed.empty()) << "nobody saw them leave";
  EXPECT_EQ(s.hub.members("OR").size(), members);
  EXPECT_EQ(proxy.accepted(), 4) << "each one's first connection, then one each after the cut";

  stop = true;
  for (auto& t : viewers) t.join();
  for (const auto& p : people) {
    SCOPED_TRACE(p->name);
    EXPECT_EQ(p->error, "");
    EXPECT_EQ(p->result.session_name, "OR");
    EXPECT_EQ(p->result.ended, ViewerEnd::kInterrupted) << p->result.error;
    ASSERT_EQ(p->result.outages.size(), 1u);
    EXPECT_NE(p->result.outages[0].why.find("receive timeout"), std::string::npos)
        << p->result.outages[0].why;
  }
}

}  // namespace
}  // namespace volcast
