#pragma once
// A tier (volcast/core/tier.hpp) as a person writes it: "DEPTH/COLOR[/QUALITY][@N]" wherever one
// is named (flags, logs, stats), e.g. "volcast/jpeg", "volcast-n2/jpeg/70", "h264/h264/50@2";
// parsed against the codecs this build has (registry.hpp).
#include <string>
#include <string_view>

#include "volcast/core/tier.hpp"

namespace volcast {

/// Whether a tier written with @N may be parsed (a server's ladder) or only tiers of every frame
/// set (a recording, a tier published on NATS, a client's request).
enum class TierRate { kAny, kEveryFrameSet };

/// Parses "DEPTH/COLOR", "DEPTH/COLOR/QUALITY" (0..100, 0: the codec's default), either with
/// "@N" (N 1..8) when `rate` allows it. Throws Error starting with `what` (a flag such as
/// "--tier", or "server: offered tier") and the text for a malformed text, a codec this build
/// does not have (registry.hpp), a quality outside 0..100, a divisor outside 1..8 or one `rate`
/// does not allow.
Tier parse_tier(std::string_view text, const std::string& what, TierRate rate = TierRate::kAny);

/// The text parse_tier reads: "volcast/jpeg", "h264/h264/50@2" (quality 0 and divisor 1 are left
/// out), so parse_tier(to_string(t)) == t.
std::string to_string(const Tier& tier);

}  // namespace volcast
