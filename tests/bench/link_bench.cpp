// volcast_link_bench: the stream over impaired paths (network namespaces + the userspace relay of
// support/impaired_link; needs root), new pacing beside the old fixed window of two frame sets in
// the same run. Usage: volcast_link_bench [seconds per run, default 8]
#include <cstdio>
#include <cstdlib>
#include <string>

#include <spdlog/spdlog.h>

#include "support/impaired_stream.hpp"
#include "support/test_paths.hpp"

int main(int argc, char** argv) {
  using namespace volcast;
  const double seconds = argc > 1 ? std::atof(argv[1]) : 8.0;
  spdlog::set_level(spdlog::level::warn);
  struct Path {
    const char* name;
    LinkImpairment impairment;
  };
  const Path paths[] = {
      {"none (namespaces only)", {}},
      {"50 ms RTT", {.one_way_delay_us = 25'000}},
      {"100 ms RTT", {.one_way_delay_us = 50'000}},
      {"50 ms RTT + 5% loss", {.one_way_delay_us = 25'000, .loss = 0.05}},
      {"50 ms RTT + 30 Mbit/s", {.one_way_delay_us = 25'000, .rate_bits_per_s = 30e6}},
  };
  std::printf("2 real cameras (hands + Azure Kinect), volcast/jpeg, one receive-only viewer\n");
  std::printf("%-24s %-14s %7s %9s %9s %7s %8s\n", "path", "pacing", "fps", "lat p50", "lat p99",
              "window", "skipped");
  for (const Path& p : paths)
    for (int window : {2, 8}) {
      std::string why;
      auto link = ImpairedLink::create(p.impairment, &why);
      if (!link) {
        std::fprintf(stderr, "cannot make the link: %s\n", why.c_str());
        return 2;
      }
      const PathRun r = run_over_link(*link, test::paths::data(), seconds, window);
      std::printf("%-24s %-14s %7.1f %7.1fms %7.1fms %7d %8llu\n", p.name,
                  window == 2 ? "fixed 2 (old)" : "BDP (new)", r.fps, r.latency_ms_p50,
                  r.latency_ms_p99, r.window, static_cast<unsigned long long>(r.skipped));
      std::fflush(stdout);
    }
  return 0;
}
