#pragma once
// A tier: one way a site's stream is encoded, shared by every viewer that receives it (the
// paper's per-codec sharing: each frame set is encoded once per tier, not once per viewer).
// Written "DEPTH/COLOR[/QUALITY][@N]" wherever a person names one (flags, logs, stats), e.g.
// "volcast/jpeg", "volcast-n2/jpeg/70", "h264/h264/50@2": volcast/codec/tier.hpp parses and
// formats it against the codecs this build has. A plain value here, so that what carries a tier
// below the codecs (core's EncodedFrameSetBody) names it the same way.
#include <string>

namespace volcast {

struct Tier {
  std::string depth_codec;  ///< a depth codec's registry name ("volcast", "h264")
  std::string color_codec;  ///< a color codec's registry name ("jpeg", "none")
  int color_quality = 0;    ///< 1..100; 0: the color codec's default
  int frame_divisor = 1;    ///< 1..8: the site frame sets whose sequence it divides (1: all)
  bool operator==(const Tier&) const = default;
};

}  // namespace volcast
