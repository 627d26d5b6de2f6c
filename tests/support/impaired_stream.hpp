#pragma once
// Runs the real two-camera site over an ImpairedLink (server namespace -> client namespace) with
// one receive-only viewer and reports what it got. Shared by the test and the link benchmark.
#include <filesystem>

#include "volcast/bench/impaired_link.hpp"

namespace volcast {

struct PathRun {
  double fps = 0;                                 ///< frame sets received per second
  double latency_ms_p50 = 0, latency_ms_p99 = 0;  ///< capture -> whole message received
  /// max of send - capture over the frame sets the site encoded within the latency budget (the
  /// server sends one encoded later while it is the newest: server.hpp)
  double worst_send_age_ms = 0;
  uint64_t encoded_late = 0;  ///< frame sets the site encoded only past the budget
  double min_rtt_ms = 0;      ///< the server's path estimate
  int window = 0;             ///< frame sets the server allowed in flight
  uint64_t frames = 0, skipped = 0;
};

/// What the site publishes.
enum class Demand {
  /// The real site at 30 fps, each frame set read and encoded (what `volcast_link_bench` measures;
  /// a loaded machine's site sends fewer).
  kSite,
  /// The site's first frame set again and again (fresh capture times, the same frames: the
  /// stateless tier sends their bytes again without encoding), each as soon as the server has sent
  /// the one before: the demand stays ahead of what the pacing window lets through, whatever the
  /// machine's load, so the window is the only limit.
  kAheadOfThePath,
};

/// Streams `seconds` (after 1 s of warm-up) and returns the figures. Throws Error on failure.
/// `max_window` 2 reproduces the old fixed window of two unacknowledged frame sets.
PathRun run_over_link(ImpairedLink& link, const std::filesystem::path& data, double seconds,
                      int max_window = 8, Demand demand = Demand::kSite);

}  // namespace volcast
