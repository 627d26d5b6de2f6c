#include "tier_budget.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "tier_encoder.hpp"
#include "volcast/core/error.hpp"

namespace volcast::detail {

// The rate is the mean over the last 33 publish() calls (once they span 1 s or are 33): a
// publisher that catches up in bursts (a replay woken late) publishes at its mean rate, where the
// median gap between its frame sets (0 inside a burst) made it look 1000 fps.
void TierBudget::note_published(int64_t now_us) {
  published_us.push_back(now_us);
  if (published_us.size() > 33) published_us.pop_front();
  const int64_t span_us = now_us - published_us.front();
  if (published_us.size() < 3 || (span_us < 1'000'000 && published_us.size() < 33)) return;
  const double fps = std::clamp(
      double(published_us.size() - 1) * 1e6 / double(std::max<int64_t>(span_us, 1)), 1.0, 1000.0);
  if (fps >= peak_fps || now_us - peak_us > 30'000'000) {
    peak_fps = fps;
    peak_us = now_us;
  }
}

double TierBudget::encode_ns(const Tier& key) const {
  const double estimate = tier_encode_ns(key, site_pixels) / key.frame_divisor;
  return passed_through == key ? 0 : estimate;
}

void check_tier_fits(const TierBudget& budget, const std::string& name, double cost,
                     const TierLoad& load, int max_alone, bool share) {
  if (load.total + cost > budget.cores)
    throw Error(fmt::format(
        "tier {} would cost about {:.2f} CPU cores; the tiers' budget is {:.2f} cores "
        "(--tier-cpu-budget), {:.2f} in use: choose cheaper codecs or a tier already watched",
        name, cost, budget.cores, load.total));
  if (!share) return;
  if (load.alone_count >= max_alone)
    throw Error(
        fmt::format("your address holds {} tiers nobody else watches, the most per address "
                    "(--max-tiers-per-address): choose the codecs of a viewer already watching",
                    load.alone_count));
  if (load.alone + cost > budget.cores / 2)
    throw Error(fmt::format(
        "tier {} would cost about {:.2f} CPU cores; your address's own tiers use {:.2f} of its "
        "share, {:.2f} cores (half the --tier-cpu-budget): choose cheaper codecs",
        name, cost, load.alone, budget.cores / 2));
}

}  // namespace volcast::detail
