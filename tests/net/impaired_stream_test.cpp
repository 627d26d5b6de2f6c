// Pacing on impaired paths: the server in one network namespace, the viewer in another, joined by
// the userspace relay of tests/support/impaired_link (this kernel has no netem). Real recordings
// (the demo's two cameras). Bounds are loose (a loaded 2-core machine, sanitizers); the real
// figures come from `volcast_link_bench` (bench/link_benchmark.cpp).
#include <gtest/gtest.h>

#include <thread>

#include "support/impaired_stream.hpp"
#include "support/test_data.hpp"
#include "volcast/bench/impaired_link.hpp"

namespace volcast {
namespace {

TEST(ImpairedPath, HundredMsRoundTripKeepsTheFullFrameRate) {
  // 50 ms each way: the old fixed window of 2 frame sets capped this at 2 / 0.1 s = 20 fps.
  std::string why;
  auto link = ImpairedLink::create({.one_way_delay_us = 50'000}, &why);
  if (!link) GTEST_SKIP() << why;
  // The site's frame sets published ahead of the path (each as soon as the one before was sent,
  // without encoding): the window alone limits what is in flight, on an idle or a loaded machine.
  const PathRun r = run_over_link(*link, test::data_dir(), 4.0, 8, Demand::kAheadOfThePath);
  std::printf("100 ms RTT: %.1f fps, latency p50 %.1f ms p99 %.1f ms, window %d, RTT %.1f ms\n",
              r.fps, r.latency_ms_p50, r.latency_ms_p99, r.window, r.min_rtt_ms);
  // The fixed window could not pass 2 frame sets per round trip (20 fps here). The window is
  // twice the frame sets in flight at the rate that came (pacing.hpp: 2 x BDP): with the demand
  // always ahead, even 2 in flight give a window of 4, so 3 or more shows it opened past the old
  // one. The frame rate itself is a figure, printed above and measured by volcast_link_bench
  // (the real site), not an assertion.
  EXPECT_GE(r.window, 3);
  EXPECT_GT(r.frames, 0u);
  EXPECT_GE(r.min_rtt_ms, 100.0);
  // The latency budget, checked by the sender exactly (but for frame sets the loaded site
  // encoded only past it: sent while newest, server.hpp).
  EXPECT_LE(r.worst_send_age_ms, 150.0) << r.encoded_late << " encoded late";
}

TEST(ImpairedPath, FiftyMsRoundTripWithFivePercentLossStaysWithinTheBudget) {
  std::string why;
  auto link = ImpairedLink::create({.one_way_delay_us = 25'000, .loss = 0.05}, &why);
  if (!link) GTEST_SKIP() << why;
  const PathRun r = run_over_link(*link, test::data_dir(), 4.0);
  const auto c = link->counters();
  std::printf(
      "50 ms RTT + 5%% loss: %.1f fps, latency p50 %.1f ms p99 %.1f ms, %llu packets lost\n", r.fps,
      r.latency_ms_p50, r.latency_ms_p99,
      static_cast<unsigned long long>(c.server_to_client.dropped_loss));
  EXPECT_GT(c.server_to_client.dropped_loss, 0u);
  // The stream goes on through the losses (about 12 fps idle, ~48 frame sets in the 4 s; a loaded
  // box gets fewer): frame sets arrived and the viewer is still served at the end.
  EXPECT_GT(r.frames, 0u);
  EXPECT_GE(r.window, 1);
  // Nothing the site encoded within the budget was sent older than it, exactly.
  EXPECT_LE(r.worst_send_age_ms, 150.0) << r.encoded_late << " encoded late";
  // The latency the viewer sees (budget + path + loss recovery) is a figure, not a test: printed
  // above, measured by volcast_link_bench.
}

}  // namespace
}  // namespace volcast
