#pragma once
// Internal to volcast_net_stream: the CPU the tiers may use (ServerConfig::tier_cpu_budget,
// server.hpp) and the site frame rate their cost is counted at. A tier's cost is its estimated
// encode time per frame set (tier_encoder.hpp tier_encode_ns) times the site's rate, in cores.
#include <cstdint>
#include <deque>
#include <optional>
#include <string>

#include "volcast/codec/tier.hpp"

namespace volcast::detail {

struct TierBudget {
  double cores = 1;          // the tiers' budget (cores): tier_cpu_budget, the default worked out
  uint64_t site_pixels = 0;  // depth pixels of every camera together
  // The publisher's own tier passes its bytes through (ServerConfig::passed_through_tier): free.
  std::optional<Tier> passed_through;
  std::deque<int64_t> published_us;  // steady times (µs) of the last publish() calls (at most 33)
  double peak_fps = 0;               // see note_published()
  int64_t peak_us = 0;

  // Notes a publish() at steady time `now_us` and updates peak_fps, the highest rate seen in the
  // last 30 s, so that a publisher slowed for a while by a busy machine does not make the tiers
  // look cheap.
  void note_published(int64_t now_us);
  // The site's frame rate for tier costs; 30 before its first second of frame sets.
  double site_fps() const { return peak_fps > 0 ? peak_fps : 30; }
  // Cores used by a tier costing `encode_ns` per site frame set.
  double cores_of(double encode_ns) const { return encode_ns * site_fps() / 1e9; }
  // Estimated encode time (ns) per site frame set of `key`: 1/N of it for a tier of every Nth
  // frame set, 0 for the passed-through tier. Throws Error naming an unknown codec.
  double encode_ns(const Tier& key) const;
};

// What the running tiers cost (cores): all, and those one address's viewers hold alone (count
// and cost).
struct TierLoad {
  double total = 0;
  double alone = 0;
  int alone_count = 0;
};

// Throws Error (its text fits the 200 characters a viewer shows of a Reject) if a new tier
// `name` costing `cost` cores would take `load` past the budget, or -- with `share` -- the tiers
// its address holds alone past `max_alone` tiers or half the budget.
void check_tier_fits(const TierBudget& budget, const std::string& name, double cost,
                     const TierLoad& load, int max_alone, bool share);

}  // namespace volcast::detail
