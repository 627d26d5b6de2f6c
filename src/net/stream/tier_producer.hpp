#pragma once
// Internal to volcast_net_stream: a tier as the producer of a selective forwarding unit -- one
// encoding thread turns the site's newest frame set into the tier's (tier_encoder.hpp), and every
// viewer subscribed to it, and every tap (a recorder), takes that one encoding
// (server_tiers.cpp runs it).
#include <deque>
#include <functional>
#include <memory>
#include <thread>
#include <utility>
#include <vector>

#include "tier_encoder.hpp"
#include "volcast/net/stream/server.hpp"
#include "wake_fd.hpp"

namespace volcast::detail {

struct TierProducer {
  TierProducer(Tier key, size_t cameras) : encoder(std::move(key), cameras) {}

  // A consumer that takes every frame set (Server::add_tier_tap), and whether it has begun (at a
  // key frame set).
  struct Tap {
    uint64_t id = 0;
    std::shared_ptr<std::function<void(const TierFrameSet&)>> fn;
    bool begun = false;
  };

  TierEncoder encoder;  // used by the tier's thread only
  std::thread thread;
  // The rest is guarded by the server's mutex.
  std::shared_ptr<const EncodedFrames> latest;
  std::vector<const WakeFd*> subscribers;  // the viewers' threads to wake for each frame set
  std::vector<Tap> taps;
  bool key_wanted = true;
  bool stop = false;
  TierReport report;
  double encode_ms_total = 0;
  double encode_ns = 0;    // estimated CPU per site frame set (TierBudget::encode_ns)
  double cpu_ms_mean = 0;  // measured codec CPU per frame set, moving average
  // Body bytes of the frame sets encoded in the last second, with their steady times (µs): the
  // tier's rate for the viewers' rate control.
  std::deque<std::pair<int64_t, size_t>> produced;

  // Nobody watches or taps it: it encodes nothing and is reaped.
  bool idle() const { return subscribers.empty() && taps.empty(); }

  // Counts `encoded`, encoded in `wall_ms` at steady time `now_us`, in the report and the rate
  // (report.mbit_s, over the last second). Returns whether the rate was measured anew.
  bool note_encoded(const EncodedFrames& encoded, double wall_ms, int64_t now_us);

  // The report with its viewers, means and cost (`cores_per_ns`: cores per ns a frame set).
  TierReport report_now(double cores_per_ns) const;
};

}  // namespace volcast::detail
