#pragma once
// Internal to volcast_net_stream: the tiers a server offers and its ladder of rungs an adaptive
// viewer moves along (ServerConfig::offered_tiers, ladder, ladder_sizes; server.hpp), and which
// rungs one viewer may be put on.
#include <cstdint>
#include <map>
#include <span>
#include <string>
#include <vector>

#include "volcast/codec/tier.hpp"

namespace volcast {
struct ServerConfig;
}

namespace volcast::detail {

// A tier the server offers: one written without a quality ("volcast/jpeg") offers every quality.
struct TierOffer {
  Tier tier;
  bool any_quality = false;
};

// Parses ServerConfig::offered_tiers (tiers of every frame set). Throws Error naming a bad one.
std::vector<TierOffer> parse_offers(const std::vector<std::string>& texts);

// Whether `offers` (empty: every tier) take a viewer of `tier`: same codecs, the quality if the
// offer names one; the frame divisor is the ladder's alone and not compared.
bool offered(const std::vector<TierOffer>& offers, const Tier& tier);

// The ladder, best rung first.
struct Ladder {
  std::vector<Tier> rungs;
  std::vector<double> sizes;  // each rung's relative size (ServerConfig::ladder_sizes), or empty
  // Each tier's last measured rate (bits/s) by name, kept after it stops: a rung not running now
  // is judged by what it produced last.
  std::map<std::string, double> learned_bits;
};

// The configured ladder, keeping the rungs `offers` take. Rungs of the default ladder whose codecs
// this build lacks (the video codecs without volcast_codec_video) are left out; a ladder given by
// hand must name codecs this build has. Throws Error naming a bad rung or size.
Ladder make_ladder(const ServerConfig& config, const std::vector<TierOffer>& offers);

// What an adaptive viewer asked for in its Hello (protocol.hpp), and what it may get.
struct ViewerFloor {
  uint8_t adapt = 0;                   // Hello::adapt flags (kAdapt, kNotify, kKeepLossless, ...)
  uint64_t max_bits_per_s = 0;         // Hello::max_bits_per_s: its cap, 0 none
  std::vector<std::string> decodes;    // Hello::decodes: the codecs it decodes; empty, any
  Tier hello_tier;                     // the tier its Hello named
  size_t top = 0;                      // the best rung it may get (its Hello's tier if a rung)
  std::vector<int64_t> refused_until;  // per rung: refused by the CPU budget until (steady µs)
};

// Per rung into `ok` (capacity reused), whether a viewer of `floor` may be put on it at steady
// time `now_us`: its floors and decoders, budget refusals, and -- with `cap` -- its cap against
// `measured_bits` (per rung, bits/s; 0 not known: under any cap).
void allowed_rungs(const Ladder& ladder, const ViewerFloor& floor, std::span<const double> measured,
                   int64_t now_us, std::vector<char>& ok, bool cap = true);

// Fills the rungs of `bits` (bits/s per rung) not measured (<= 0) from the one at `current` (or
// the first measured) scaled by the rungs' sizes; without sizes, leaves them.
void estimate_unmeasured(const Ladder& ladder, size_t current, std::span<double> bits);

}  // namespace volcast::detail
