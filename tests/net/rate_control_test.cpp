// The per-viewer rate control on synthetic Ack timelines (exact behaviour: a simulated path, no
// network, no clock): when it steps down, how far, when it probes up, that it does not oscillate,
// that floors hold and that a slow site is not taken for a slow path.
#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "volcast/net/stream/rate_control.hpp"

namespace volcast {
namespace {

// A simulated viewer: frame sets every `period_us` (30 fps: the rung's rate; slower: a slow site)
// of the current rung's size, through a path of `path_bits` per second (0: unlimited) with a 20 ms
// round trip, each Ack `late_us` later still (a loaded machine's scheduling, not a queue); a frame
// set that would queue more than 150 ms behind the others is skipped, as the server's pacing does.
// Each send tells whether every earlier frame set was acknowledged (the server's frames in
// flight). The minimum round trip is the smallest seen, as the pacer's (pacing.hpp): it includes
// a frame set's own transmission.
struct SimPath {
  std::vector<double> rung_bits{60e6, 30e6, 12e6, 4e6};
  std::vector<char> allowed{1, 1, 1, 1};
  double path_bits = 0;
  int64_t period_us = 33'333;
  int64_t late_us = 0;
  int64_t now = 0;
  int64_t link_free = 0;    // when the bottleneck has sent everything given to it
  int64_t acked_until = 0;  // when the last frame set sent is acknowledged
  int64_t min_rtt = INT64_MAX;
  std::vector<std::pair<int64_t, size_t>> switches;  // (time, rung)
  std::vector<int64_t> notices;

  // Runs `seconds` of frame sets through `rc`, applying its decisions.
  void run(RateController& rc, double seconds) {
    const int64_t end = now + int64_t(seconds * 1e6);
    for (; now < end; now += period_us) {
      const size_t bytes = size_t(rung_bits[rc.rung()] / 8 / 30);
      const int64_t start = std::max(now, link_free);
      if (path_bits > 0 && start - now > 150'000) {
        rc.on_skip(now);
      } else {
        rc.on_send(now, acked_until <= now);
        const int64_t sent = path_bits > 0 ? start + int64_t(double(bytes) * 8e6 / path_bits) : now;
        link_free = sent;
        const int64_t rtt = sent + 20'000 + late_us - now;
        min_rtt = std::min(min_rtt, rtt);
        acked_until = now + rtt;
        rc.on_ack(acked_until, bytes, rtt, min_rtt);
      }
      RateDecision d;
      if (rc.decide(now, rung_bits, allowed, d)) {
        if (d.notice) {
          notices.push_back(now);
        } else {
          rc.switched(d.rung, now, d.up);
          switches.emplace_back(now, d.rung);
        }
      }
    }
  }
};

RateControlConfig quick() {
  RateControlConfig c;
  c.hold_us = 2'000'000;
  c.max_hold_us = 16'000'000;
  return c;
}

TEST(RateControl, AnUnlimitedPathStaysOnTheBestRung) {
  SimPath p;
  RateController rc(4, 0, quick());
  p.run(rc, 20);
  EXPECT_EQ(rc.rung(), 0u);
  EXPECT_TRUE(p.switches.empty());
}

TEST(RateControl, APathThatShrinksIsLeftWithinASecondForTheBestRungThatFits) {
  SimPath p;
  RateController rc(4, 0, quick());
  p.run(rc, 3);
  p.path_bits = 20e6;  // 60 -> 20 Mbit/s: 12 Mbit/s fits (<= 0.8 x 20), 30 does not
  const int64_t shrunk = p.now;
  p.run(rc, 3);
  ASSERT_FALSE(p.switches.empty());
  EXPECT_LE(p.switches.front().first - shrunk, 1'000'000) << "stepped down within 1 s";
  EXPECT_EQ(p.switches.front().second, 2u) << "straight to the rung that fits, not one at a time";
  EXPECT_EQ(rc.rung(), 2u);
}

TEST(RateControl, ARecoveredPathIsProbedBackUpAndAPathBetweenRungsIsNotOscillatedOn) {
  SimPath p;
  RateController rc(4, 0, quick());
  p.path_bits = 20e6;
  p.run(rc, 60);
  // Between 12 (fits) and 30 Mbit/s (does not): probes of rung 1 fail, each hold twice the last
  // (2, 4, 8, 16 s, then 16 s each): few switches in a minute, and it ends where the path fits.
  const auto ups = std::count_if(p.switches.begin(), p.switches.end(),
                                 [](const auto& s) { return s.second == 1; });
  EXPECT_GE(ups, 2) << "it kept probing";
  EXPECT_LE(ups, 6) << "but backed off";
  EXPECT_EQ(rc.rung(), 2u);
  std::vector<int64_t> probes;
  for (const auto& s : p.switches)
    if (s.second == 1) probes.push_back(s.first);
  for (size_t i = 2; i < probes.size(); ++i)
    EXPECT_GE(probes[i] - probes[i - 1], probes[i - 1] - probes[i - 2] - 100'000)
        << "the gaps between probes never shrink";
  p.path_bits = 0;  // recovered: back to the best rung, a probe at a time
  p.switches.clear();
  p.run(rc, 40);
  EXPECT_EQ(rc.rung(), 0u);
  ASSERT_GE(p.switches.size(), 2u);
  EXPECT_EQ(p.switches.back().second, 0u);
}

TEST(RateControl, AFloorKeepsTheRungAndGivesANoticeInsteadAtMostOncePerHold) {
  SimPath p;
  p.allowed = {1, 1, 0, 0};  // e.g. lossless depth only on rungs 0 and 1
  RateController rc(4, 0, quick());
  p.path_bits = 8e6;  // not even rung 1 (30 Mbit/s) fits
  p.run(rc, 10);
  ASSERT_EQ(p.switches.size(), 1u);
  EXPECT_EQ(p.switches[0].second, 1u) << "the lightest rung the floor allows";
  EXPECT_EQ(rc.rung(), 1u);
  ASSERT_GE(p.notices.size(), 1u);
  for (size_t i = 1; i < p.notices.size(); ++i)
    EXPECT_GE(p.notices[i] - p.notices[i - 1], quick().hold_us);
}

TEST(RateControl, ASlowSiteWithoutAQueueIsNotTakenForASlowPath) {
  // Frame sets come at half the rung's rate (the site encodes slowly), each acknowledged after
  // the bare round trip: goodput is below the rung's rate, but nothing queues and nothing is
  // skipped.
  RateController rc(4, 0, quick());
  const std::vector<double> rates{60e6, 30e6, 12e6, 4e6};
  const std::vector<char> allowed{1, 1, 1, 1};
  for (int64_t now = 0; now < 10'000'000; now += 66'666) {
    rc.on_ack(now + 20'000, size_t(60e6 / 8 / 30), 20'000, 20'000);
    RateDecision d;
    EXPECT_FALSE(rc.decide(now, rates, allowed, d)) << d.reason;
  }
}

TEST(RateControl, ASlowSiteWhoseAcksAllComeLateOnAFastPathKeepsTheBestRung) {
  // The server's first seconds on a loaded machine (a quiet clean run of 568b2a0 stepped a viewer
  // of an unlimited path down: "the path delivers 2.0 Mbit/s (queue 55 ms, 0 frame sets missed)
  // where this tier needs 7.4"): the site makes 12 frame sets a second, 40 % of the rung's rate,
  // and after the first second every Ack comes 55 ms late. Goodput is short of the rung's rate and
  // the Acks read as a standing queue, but each frame set was acknowledged before the next was
  // sent: the window is application-limited, the path is not the limit.
  SimPath p;
  p.period_us = 83'333;
  RateController rc(4, 0, quick());
  p.run(rc, 1);
  p.late_us = 55'000;
  p.run(rc, 10);
  EXPECT_TRUE(p.switches.empty()) << "stepped down to " << p.switches.front().second;
  EXPECT_TRUE(p.notices.empty());
  EXPECT_EQ(rc.rung(), 0u);
  // The same Acks without the sends (as before the windows were marked): a deficit and a queue,
  // congested -- what the marking keeps from a step down.
  RateController unmarked(4, 0, quick());
  const std::vector<double> rates{60e6, 30e6, 12e6, 4e6};
  const std::vector<char> allowed{1, 1, 1, 1};
  bool stepped = false;
  for (int64_t now = 0; now < 11'000'000 && !stepped; now += 83'333) {
    const int64_t late = now >= 1'000'000 ? 55'000 : 0;
    unmarked.on_ack(now + 20'000 + late, size_t(60e6 / 8 / 30), 20'000 + late, 20'000);
    RateDecision d;
    stepped = unmarked.decide(now + 20'000 + late, rates, allowed, d) && d.rung > 0;
  }
  EXPECT_TRUE(stepped);
}

TEST(RateControl, ASlowSiteOnAPathSlowerStillStepsDown) {
  // The same slow site (12 frame sets a second: 24 Mbit/s of rung 0) through a 10 Mbit/s path:
  // each frame set takes 200 ms, the path never drains between them, so no window is
  // application-limited, and it steps down within a second.
  SimPath p;
  p.period_us = 83'333;
  RateController rc(4, 0, quick());
  p.run(rc, 2);
  ASSERT_TRUE(p.switches.empty());
  p.path_bits = 10e6;
  const int64_t shrunk = p.now;
  p.run(rc, 3);
  ASSERT_FALSE(p.switches.empty());
  EXPECT_LE(p.switches.front().first - shrunk, 1'000'000) << "stepped down within 1 s";
  EXPECT_GT(rc.rung(), 0u);
}

// Frame sets at 30 fps (rung 0) through a path of a 2 ms round trip, every one acknowledged after
// 2 ms but every fifteenth, which the viewer acknowledges 150 ms late (its thread not scheduled on
// a loaded machine) while the pacer holds the next four back. Returns the first step down's rung,
// or 0 if it kept the best one for 10 s.
size_t late_viewer_on_a_fast_path(RateControlConfig config) {
  const std::vector<double> rates{60e6, 30e6, 12e6, 4e6};
  const std::vector<char> allowed{1, 1, 1, 1};
  RateController rc(4, 0, config);
  int64_t held_until = 0;
  for (int i = 0; i < 300; ++i) {
    const int64_t now = int64_t(i) * 33'333;
    if (now < held_until) {
      rc.on_skip(now);
    } else {
      const int64_t rtt = i % 15 == 0 ? 152'000 : 2'000;
      rc.on_send(now, true);
      rc.on_ack(now + rtt, size_t(rates[0] / 8 / 30), rtt, 2'000);
      held_until = now + rtt;
    }
    RateDecision d;
    if (rc.decide(now, rates, allowed, d)) return d.rung;
  }
  return 0;
}

TEST(RateControl, AViewerLateNowAndThenOnAFastPathKeepsTheBestRung) {
  // A clean run's viewer beside the server (loopback, no bottleneck) stepped down 1.3 s after it
  // joined: "the path delivers 8.2 Mbit/s (queue 0 ms, 2 frame sets missed in 0.5 s) where this
  // tier needs 11.5 Mbit/s". Skips and a deficit, but the other Acks show the path carrying a
  // frame set at 2 ms, 16 times the rung's rate: the window has room, and is not congested.
  EXPECT_EQ(late_viewer_on_a_fast_path(quick()), 0u);
  // The same timeline judged without room (no Ack fast enough can count): four frame sets
  // missed and 70 % of the rung's goodput in each window with a late Ack, congested: it steps
  // down -- what room keeps it from.
  RateControlConfig no_room = quick();
  no_room.room = 1e9;
  EXPECT_GT(late_viewer_on_a_fast_path(no_room), 0u);
}

TEST(RateControl, LateAcksNowAndThenAreNotAQueueAndARecoveredPathIsProbedThroughThem) {
  // A loaded machine (CI beside stress-ng): the site makes frame sets at half the rung's rate, and
  // every sixth frame set the viewer's thread is not scheduled for 200 ms, so the Acks of what was
  // sent meanwhile come late, together; the others come after the bare 20 ms round trip. Nothing
  // queues at a bottleneck, so it must neither step down nor hold back its probes: from rung 2 it
  // probes up, a rung per hold, to the best one. (Smoothed, the late Acks read as a queue of
  // 20-90 ms: it stepped down, or stayed, and never probed.)
  RateController rc(4, 2, quick());
  const std::vector<double> rates{60e6, 30e6, 12e6, 4e6};
  const std::vector<char> allowed{1, 1, 1, 1};
  std::vector<size_t> rungs;
  int64_t stalled_until = 0;
  int n = 0;
  for (int64_t now = 0; now < 12'000'000; now += 66'666, ++n) {
    if (n % 6 == 0) stalled_until = now + 200'000;
    const int64_t acked_at = std::max(now + 20'000, stalled_until + 20'000);
    rc.on_ack(acked_at, size_t(rates[rc.rung()] / 8 / 30), acked_at - now, 20'000);
    RateDecision d;
    if (rc.decide(acked_at, rates, allowed, d)) {
      ASSERT_FALSE(d.notice) << d.reason;
      ASSERT_TRUE(d.up) << "stepped down to " << d.rung << ": " << d.reason;
      rc.switched(d.rung, acked_at, d.up);
      rungs.push_back(d.rung);
    }
  }
  EXPECT_EQ(rungs, (std::vector<size_t>{1, 0}));
  EXPECT_EQ(rc.rung(), 0u);
}

}  // namespace
}  // namespace volcast
