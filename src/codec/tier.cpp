#include "volcast/codec/tier.hpp"

#include "volcast/codec/registry.hpp"
#include "volcast/core/error.hpp"

namespace volcast {

Tier parse_tier(std::string_view text, const std::string& what, TierRate rate) {
  const bool any_rate = rate == TierRate::kAny;
  const auto bad = [&] {
    return Error(what + " '" + std::string(text) + "' must be DEPTH/COLOR or DEPTH/COLOR/QUALITY" +
                 (any_rate ? ", optionally @N (every Nth frame set, N 1..8)," : "") +
                 " with codecs this build has (volcast view --help lists them) and a quality "
                 "0..100 (0: the codec's default)");
  };
  const auto number = [&](std::string_view q, int lo, int hi) {
    if (q.empty() || q.size() > 3 || q.find_first_not_of("0123456789") != std::string_view::npos)
      throw bad();
    int v = 0;
    for (const char c : q) v = v * 10 + (c - '0');
    if (v < lo || v > hi) throw bad();
    return v;
  };
  Tier tier;
  std::string_view rest = text;
  if (const size_t at = rest.find('@'); at != std::string_view::npos) {
    if (!any_rate)
      throw Error(what + " '" + std::string(text) +
                  "': this tier carries every frame set (no @N; @N is for a server's ladder)");
    tier.frame_divisor = number(rest.substr(at + 1), 1, 8);
    rest = rest.substr(0, at);
  }
  const size_t a = rest.find('/');
  if (a == std::string_view::npos) throw bad();
  const size_t b = rest.find('/', a + 1);
  tier.depth_codec = std::string(rest.substr(0, a));
  tier.color_codec = std::string(rest.substr(a + 1, b == std::string_view::npos ? b : b - a - 1));
  if (b != std::string_view::npos) tier.color_quality = number(rest.substr(b + 1), 0, 100);
  if (!find_depth_codec(tier.depth_codec) || !find_color_codec(tier.color_codec)) throw bad();
  return tier;
}

std::string to_string(const Tier& tier) {
  std::string s = tier.depth_codec + "/" + tier.color_codec;
  if (tier.color_quality > 0) s += "/" + std::to_string(tier.color_quality);
  if (tier.frame_divisor > 1) s += "@" + std::to_string(tier.frame_divisor);
  return s;
}

}  // namespace volcast
