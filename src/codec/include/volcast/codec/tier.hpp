#pragma once
// A tier: one way a site's stream is encoded, shared by every viewer that receives it (the
// paper's per-codec sharing: each frame set is encoded once per tier, not once per viewer).
// Written "DEPTH/COLOR[/QUALITY][@N]" wherever a person names one (flags, logs, stats), e.g.
// "volcast/jpeg", "volcast-n2/jpeg/70", "h264/h264/50@2".
#include <string>
#include <string_view>

namespace volcast {

struct Tier {
  std::string depth_codec;  ///< a depth codec's registry name ("volcast", "h264")
  std::string color_codec;  ///< a color codec's registry name ("jpeg", "none")
  int color_quality = 0;    ///< 1..100; 0: the color codec's default
  int frame_divisor = 1;    ///< 1..8: the site frame sets whose sequence it divides (1: all)
  bool operator==(const Tier&) const = default;
};

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
