// The patient case in a session: grabbing with one owner at a time, synchronised poses and
// releases, late joiners, the monitor's shared state and swapping the case, over the real stream
// (TLS, join token) of the real hands site. The case here is synthetic (a tetrahedron and a tiny
// 3-slice series) for exact behaviour; real organs: assets_test and the demo.
#include <gtest/gtest.h>

#include <thread>

#include <fstream>

#include "support/session_site.hpp"
#include "volcast/assets/case_watch.hpp"
#include "volcast/session/objects.hpp"

namespace volcast {
namespace {

using namespace std::chrono_literals;
using test::eventually;
using test::hand_driven;
using test::named;
using test::same_pose;
using test::SessionSite;
using test::TestParticipant;
using test::turned;

// Synthetic: one object (a tetrahedron, 10 cm) and a 4 x 2 x 3 series with an overlay.
SharedCase synthetic_case(const std::string& name = "synthetic") {
  SharedCase c;
  c.name = name;
  c.objects.push_back(test::tetrahedron("organ", {0, 1.3f, 0}, {0.6f, 0.2f, 0.1f, 0.5f}));
  MonitorSeries m;
  m.width = 4, m.height = 2, m.slices = 3;
  m.hu.assign(24, 40);
  m.overlay.assign(24, 0);
  m.overlay[5] = 1;
  m.overlay_label = "Liver";
  c.monitor = m;
  return c;
}

// The case arrives before the objects' and the monitor's state (7 MB of organs and CT in the
// demo, on a loaded machine for a good while): a scripted event due in between waits for them.
TEST(SessionCase, AScriptedEventWaitsForTheStateItChangesAndIsPerformedOnce) {
  PoseScript script = idle_pose_script();
  script.monitor.push_back({0.8, 2, 90.f, 150.f, true});
  script.grabs.push_back({1.0, 2.0, "organ", 60});
  ScriptedObjects scripted(script);
  const SharedCase c = synthetic_case();
  SessionSnapshot now;
  now.id = 7;
  EXPECT_TRUE(scripted.due(nullptr, now, 5).empty()) << "nothing before the case";
  EXPECT_TRUE(scripted.due(&c, now, 5).empty()) << "the case alone: no monitor or object state";
  EXPECT_FALSE(scripted.done());

  MonitorState server;
  server.generation = 3, server.slice = 1, server.center = 40, server.width = 400;
  now.monitor = server;
  auto a = scripted.due(&c, now, 5);
  ASSERT_EQ(a.size(), 1u) << "the monitor's state arrived: its change, the grab still waits";
  EXPECT_EQ(a[0].kind, ScriptAction::Kind::kMonitor);
  EXPECT_EQ(a[0].monitor.slice, 2);
  EXPECT_EQ(a[0].monitor.center, 90.f);
  EXPECT_EQ(a[0].monitor.width, 150.f);
  EXPECT_TRUE(a[0].monitor.overlay);
  EXPECT_EQ(a[0].monitor.generation, 3u);

  ObjectView organ;
  organ.pose.position = {0, 1.3f, 0};
  now.objects.push_back(organ);
  a = scripted.due(&c, now, 5);
  ASSERT_EQ(a.size(), 1u) << "the objects' state arrived: the grab, once; the monitor not again";
  EXPECT_EQ(a[0].kind, ScriptAction::Kind::kGrab);
  EXPECT_EQ(a[0].object, 0);
  EXPECT_TRUE(scripted.due(&c, now, 5.5).empty()) << "not its owner yet: no move";
  now.objects[0].owner = 7;
  const auto turned = [&](const ScriptAction& x) {
    return x.pose.orientation.angularDistance(organ.pose.orientation) * 180 / M_PI;
  };
  a = scripted.due(&c, now, 6.0);
  ASSERT_EQ(a.size(), 1u);
  EXPECT_EQ(a[0].kind, ScriptAction::Kind::kMove) << "held from when the server handed it over";
  EXPECT_FALSE(scripted.done()) << "holding";
  EXPECT_NEAR(turned(a[0]), 0, 1e-3) << "the first move: where it was";
  EXPECT_TRUE(scripted.due(&c, now, 6.05).empty()) << "the next step is due 0.1 s later";
  // 2 s at 10 steps a second: 20 steps of 6 degrees, each due 0.1 s after the one before from
  // the hand-over (6 s), not from the asking (5 s); one waits while the one before is queued.
  a = scripted.due(&c, now, 6.1, true);
  EXPECT_TRUE(a.empty()) << "the move before still queued: the next waits (never coalesced)";
  a = scripted.due(&c, now, 6.1);
  ASSERT_EQ(a.size(), 1u);
  EXPECT_NEAR(turned(a[0]), 6, 1e-3);
  // A machine that fell behind: every step still goes out, one per call, in order.
  std::vector<double> angles;
  for (int call = 0; call < 40 && !scripted.done(); ++call) {
    a = scripted.due(&c, now, 20.0);
    ASSERT_EQ(a.size(), 1u);
    if (a[0].kind == ScriptAction::Kind::kRelease) {
      EXPECT_NEAR(turned(a[0]), 120, 1e-3) << "turned 60 degrees/s for the scripted 2 s";
      break;
    }
    EXPECT_EQ(a[0].kind, ScriptAction::Kind::kMove);
    angles.push_back(turned(a[0]));
  }
  ASSERT_EQ(angles.size(), 19u) << "steps 2 to 20 after the first two";
  for (size_t k = 0; k < angles.size(); ++k) EXPECT_NEAR(angles[k], 12 + 6 * double(k), 1e-3);
  EXPECT_TRUE(scripted.done());
  EXPECT_TRUE(scripted.due(&c, now, 21).empty());
}

// A grab the server never hands over (another holds the object) is given up, not held forever.
TEST(SessionCase, AScriptedGrabTheServerNeverHandsOverIsGivenUp) {
  PoseScript script;
  script.grabs.push_back({1.0, 2.0, "liver", 60});
  ScriptedObjects scripted(script);
  SharedCase c;
  c.generation = 1;
  SharedObject liver;
  liver.name = "liver";
  c.objects.push_back(liver);
  SessionSnapshot now;
  now.id = 7;
  now.case_generation = 1;
  now.objects.push_back(ObjectView{});
  now.objects[0].owner = 9;  // somebody else's
  auto a = scripted.due(&c, now, 1.0);
  ASSERT_EQ(a.size(), 1u);
  EXPECT_EQ(a[0].kind, ScriptAction::Kind::kGrab);
  EXPECT_TRUE(scripted.due(&c, now, 5).empty()) << "waiting: no move, no release";
  EXPECT_TRUE(scripted.due(&c, now, 13.5).empty()) << "given up after 2 + 10 s, nothing sent";
  now.objects[0].owner = 7;  // too late: it is no longer asked for
  EXPECT_TRUE(scripted.due(&c, now, 14).empty());
}

TEST(SessionCase, AScriptedMonitorChangeForACaseWithoutASeriesIsDropped) {
  PoseScript script = idle_pose_script();
  script.monitor.push_back({0.5, 1, std::nullopt, std::nullopt, std::nullopt});
  ScriptedObjects scripted(script);
  SharedCase c = synthetic_case();
  c.monitor.reset();
  SessionSnapshot now;
  EXPECT_TRUE(scripted.due(&c, now, 1).empty());
  now.monitor = MonitorState{};
  EXPECT_TRUE(scripted.due(&c, now, 1).empty()) << "dropped, not kept for a later case";
}

TEST(SessionCase, TwoGrabsAtOnceGiveOneOwnerAndEveryoneSeesTheFinalPose) {
  SessionSite s;
  s.hub.set_case(synthetic_case());
  TestParticipant a(s, hand_driven("Dr. A")), b(s, hand_driven("Dr. B"));
  ASSERT_TRUE(eventually([&] {
    return a.now().objects.size() == 1 && b.now().objects.size() == 1 && a.now().joined &&
           b.now().joined;
  }));
  EXPECT_EQ(a.p().shared_case()->name, "synthetic");
  EXPECT_TRUE(same_pose(a.now().objects[0].pose, synthetic_case().objects[0].rest));
  // Both grab at once: the server takes them in arrival order; one wins, everyone agrees.
  std::thread ta([&] { a.p().grab(0); }), tb([&] { b.p().grab(0); });
  ta.join(), tb.join();
  ASSERT_TRUE(eventually([&] {
    const auto sa = a.now(), sb = b.now();
    return sa.objects[0].owner != 0 && sa.objects[0].owner == sb.objects[0].owner;
  }));
  ASSERT_TRUE(eventually([&] { return s.hub.stats().grabs + s.hub.stats().grabs_refused == 2; }));
  const uint32_t owner = a.now().objects[0].owner;
  EXPECT_TRUE(owner == a.now().id || owner == b.now().id);
  EXPECT_EQ(s.hub.objects("OR")[0].owner, owner);
  EXPECT_EQ(s.hub.stats().grabs, 1u);
  EXPECT_EQ(s.hub.stats().grabs_refused, 1u);
  TestParticipant& winner = owner == a.now().id ? a : b;
  TestParticipant& loser = owner == a.now().id ? b : a;
  ASSERT_TRUE(
      eventually([&] { return loser.now().last_error.find("is held by") != std::string::npos; }));
  // The loser's moves are ignored; the winner turns it, the loser sees it turn.
  loser.p().move_object(0, turned(170));
  const uint32_t granted = loser.now().objects[0].sequence;
  for (int step = 1; step <= 30; ++step) {
    winner.p().move_object(0, turned(3.0f * float(step)));
    std::this_thread::sleep_for(10ms);
  }
  // It moved while held, not only at the release: the loser sees it turned 90 degrees, held.
  ASSERT_TRUE(eventually([&] {
    const ObjectView o = loser.now().objects[0];
    return o.sequence > granted && o.owner == owner && same_pose(o.pose, turned(90));
  }));
  winner.p().release(0, turned(90));
  ASSERT_TRUE(eventually([&] {
    const auto sa = a.now(), sb = b.now();
    return sa.objects[0].owner == 0 && sb.objects[0].owner == 0 &&
           same_pose(sa.objects[0].pose, turned(90)) && same_pose(sb.objects[0].pose, turned(90));
  }));
  EXPECT_TRUE(same_pose(s.hub.objects("OR")[0].pose, turned(90)));
  EXPECT_GE(s.hub.stats().moves_ignored, 1u);
  EXPECT_EQ(s.hub.stats().releases, 1u);
  // A late joiner gets the current state: nobody holds it, where it was let go.
  // The case arrives first (each object at rest), then the objects' state, then the monitor's
  // (hub_case.cpp send_case_state): C has it all once it has the monitor. A loaded run checked
  // between the case and the state and saw the object at rest.
  TestParticipant c(s, hand_driven("Dr. C"));
  ASSERT_TRUE(eventually([&] { return c.now().objects.size() == 1 && c.now().monitor; }));
  EXPECT_EQ(c.now().objects[0].owner, 0u);
  EXPECT_TRUE(same_pose(c.now().objects[0].pose, turned(90)));
  // An owner who goes lets go where it held it.
  c.p().grab(0);
  ASSERT_TRUE(eventually([&] { return a.now().objects[0].owner == c.now().id; }));
  c.p().move_object(0, turned(45));
  ASSERT_TRUE(eventually([&] { return same_pose(s.hub.objects("OR")[0].pose, turned(45)); }));
  c.end();
  ASSERT_TRUE(
      eventually([&] { return a.now().objects[0].owner == 0 && b.now().objects[0].owner == 0; }));
  EXPECT_TRUE(same_pose(a.now().objects[0].pose, turned(45)));
}

TEST(SessionCase, TheMonitorIsSharedAndTheCaseSwapsForEveryone) {
  SessionSite s;
  s.hub.set_case(synthetic_case());
  TestParticipant a(s, hand_driven("Dr. A")), b(s, hand_driven("Dr. B"));
  ASSERT_TRUE(eventually([&] { return a.now().monitor && b.now().monitor; }));
  EXPECT_EQ(a.now().monitor->slice, 1);    // the middle one
  EXPECT_EQ(a.now().monitor->width, 400);  // abdomen
  EXPECT_TRUE(a.now().monitor->overlay);
  MonitorState want = *b.now().monitor;
  const auto liver = window_preset("liver");
  want.slice = 2, want.center = liver.center, want.width = liver.width, want.overlay = false;
  b.p().set_monitor(want);
  ASSERT_TRUE(
      eventually([&] { return a.now().monitor->slice == 2 && a.now().monitor->by == b.now().id; }));
  EXPECT_EQ(a.now().monitor->width, 150);
  EXPECT_FALSE(a.now().monitor->overlay);
  // Changes faster than the round trip build on each other (keys pressed in a row, a slider
  // dragged): each starts from the one before, not from the server's older state.
  for (const char* preset : {"abdomen", "bone"}) {
    MonitorState m = *b.now().monitor;
    ASSERT_EQ(m.slice, 2);
    m.center = window_preset(preset).center;
    m.width = window_preset(preset).width;
    b.p().set_monitor(m);
    m = *b.now().monitor;  // at once: still on its way
    EXPECT_EQ(m.width, window_preset(preset).width);
    m.slice = 0;
    b.p().set_monitor(m);
    m = *b.now().monitor;
    m.overlay = true;
    b.p().set_monitor(m);
    ASSERT_TRUE(eventually([&] {
      const auto h = s.hub.monitor("OR");
      return h->overlay && h->slice == 0 && a.now().monitor->overlay && b.now().monitor->overlay;
    }));
    EXPECT_EQ(s.hub.monitor("OR")->width, window_preset(preset).width) << preset;
    EXPECT_EQ(a.now().monitor->width, window_preset(preset).width) << preset;
    want.slice = 2, want.overlay = false;  // back, for the next round and what follows
    b.p().set_monitor(want);
    ASSERT_TRUE(eventually([&] {
      return a.now().monitor->slice == 2 && !a.now().monitor->overlay &&
             !s.hub.monitor("OR")->overlay;
    }));
  }
  // A slice past the series is refused with a reason; the state stays.
  want.slice = 3;
  b.p().set_monitor(want);
  ASSERT_TRUE(
      eventually([&] { return b.now().last_error.find("slice 3 of 3") != std::string::npos; }));
  EXPECT_EQ(s.hub.monitor("OR")->slice, 2);
  // Swapping the case: everyone gets the new one, at rest, held by nobody.
  a.p().grab(0);
  ASSERT_TRUE(eventually([&] { return b.now().objects[0].owner == a.now().id; }));
  SharedCase next = synthetic_case("next patient");
  next.objects[0].rest.position = {0.5f, 1.2f, 0};
  next.monitor.reset();
  s.hub.set_case(next);
  ASSERT_TRUE(eventually([&] {
    return a.now().case_generation == 2 && b.now().case_generation == 2 &&
           b.now().objects.size() == 1 && b.now().objects[0].owner == 0;
  }));
  EXPECT_EQ(b.p().shared_case()->name, "next patient");
  EXPECT_TRUE(same_pose(b.now().objects[0].pose, next.objects[0].rest));
  EXPECT_FALSE(b.now().monitor);
  // A move about the old case is ignored.
  a.p().move_object(0, turned(10));
  std::this_thread::sleep_for(100ms);
  EXPECT_EQ(s.hub.objects("OR")[0].owner, 0u);
  EXPECT_TRUE(same_pose(s.hub.objects("OR")[0].pose, next.objects[0].rest));
}

// Hostile requests: a grab of an object that does not exist drops only its sender.
TEST(SessionCase, AGrabOfNoSuchObjectDropsOnlyItsSender) {
  SessionSite s;
  s.hub.set_case(synthetic_case());
  TestParticipant a(s, hand_driven("Dr. A")), b(s, hand_driven("Dr. B"));
  ASSERT_TRUE(
      eventually([&] { return a.now().objects.size() == 1 && b.now().objects.size() == 1; }));
  session::ObjectRequest q{1, 7, {}};
  a.client->post_session(session::message(session::Type::kGrab, session::serialize(q, false)));
  ASSERT_TRUE(eventually([&] { return bool(a.ended); }));
  EXPECT_EQ(s.hub.stats().dropped, 1u);
  b.p().grab(0);
  ASSERT_TRUE(eventually([&] { return b.now().objects[0].owner == b.now().id; }));
}

// serve --case: the folder is watched; a new case.json is loaded and swapped for everyone, a
// broken one leaves the case shown as it is.
TEST(SessionCase, ChangingTheCaseFolderSwapsTheCaseForEveryone) {
  SessionSite s;
  const auto folder = test::temp_dir("case_watch");
  const auto organs = test::data_dir() / "medical" / "ircad11-organs";
  const auto write = [&](const std::string& name, const std::string& mesh) {
    std::ofstream(folder / "case.json.tmp")
        << R"({"name": ")" << name << R"(", "parts": [{"name": "organ", "mesh": ")"
        << (organs / mesh).string() << R"("}]})";
    std::filesystem::rename(folder / "case.json.tmp", folder / "case.json");  // whole or nothing
  };
  write("first", "liver.obj");
  CaseWatch watch(
      folder, [&](SharedCase c) { s.hub.set_case(std::move(c)); }, 60000);
  TestParticipant a(s, hand_driven("Dr. A"));
  ASSERT_TRUE(eventually([&] { return a.p().shared_case() && a.now().objects.size() == 1; }));
  EXPECT_EQ(a.p().shared_case()->name, "first");
  std::this_thread::sleep_for(1100ms);  // a new modification time
  write("second", "gallbladder.obj");
  ASSERT_TRUE(eventually([&] { return a.p().shared_case()->name == "second"; }));
  EXPECT_EQ(a.now().case_generation, 2u);
  EXPECT_TRUE(eventually([&] { return watch.reloads() == 1; }));  // counted after the send
  std::this_thread::sleep_for(1100ms);
  std::ofstream(folder / "case.json") << "{broken";
  EXPECT_TRUE(eventually([&] { return watch.failed_reloads() == 1; }));  // seen, settled, refused
  EXPECT_EQ(watch.reloads(), 1u);
  EXPECT_EQ(a.p().shared_case()->name, "second");
  EXPECT_EQ(s.hub.case_generation(), 2u);
}

}  // namespace
}  // namespace volcast
