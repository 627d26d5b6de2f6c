#include "ladder.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>

#include "volcast/codec/registry.hpp"
#include "volcast/core/error.hpp"
#include "volcast/net/stream/server.hpp"

namespace volcast {

std::vector<std::string> default_ladder() {
  return {"volcast/jpeg/70", "volcast-n2/jpeg/50", "volcast/jpeg/50@2", "h264/h264/50",
          "h264/h264/50@2"};
}

std::vector<double> default_ladder_sizes() {
  // Bytes per Azure Kinect frame (volcast bench on k4a-recording: depth volcast 83,705,
  // volcast-n2 38,235; color JPEG q70 35,362, q50 26,208) over the top rung's 119,067; @2 halves
  // it. H.264 streams with a key frame every 60: the bench's 30-frame clips (44 kB with their key
  // frame) overstate it; streamed, the Kinect's took 15.4 kB a frame (volcast bench --paths) --
  // 0.25 leaves room for a scene that moves more.
  return {1.0, 0.54, 0.46, 0.25, 0.125};
}

namespace detail {

std::vector<TierOffer> parse_offers(const std::vector<std::string>& texts) {
  std::vector<TierOffer> offers;
  for (const auto& t : texts) {
    // "DEPTH/COLOR/QUALITY" names a quality; "DEPTH/COLOR" (two parts) any.
    const bool quality_given = std::count(t.begin(), t.end(), '/') >= 2;
    offers.push_back(
        {parse_tier(t, "server: offered tier", TierRate::kEveryFrameSet), !quality_given});
  }
  return offers;
}

bool offered(const std::vector<TierOffer>& offers, const Tier& tier) {
  if (offers.empty()) return true;
  for (const auto& o : offers)
    if (o.tier.depth_codec == tier.depth_codec && o.tier.color_codec == tier.color_codec &&
        (o.any_quality || o.tier.color_quality == tier.color_quality))
      return true;
  return false;
}

Ladder make_ladder(const ServerConfig& config, const std::vector<TierOffer>& offers) {
  Ladder ladder;
  const bool default_given = config.ladder == default_ladder();
  const bool sized = config.ladder_sizes.size() == config.ladder.size();
  for (size_t i = 0; i < config.ladder.size(); ++i) {
    const std::string& t = config.ladder[i];
    if (sized && !(config.ladder_sizes[i] > 0))
      throw Error("server: ladder rung " + t + ": its size must be positive");
    Tier key;
    try {
      key = parse_tier(t, "server: ladder rung");
    } catch (const Error&) {
      // The default ladder's video rungs need volcast_codec_video (register_video_codecs):
      // without it they are left out (the default is well formed: only a codec can be missing).
      if (default_given) continue;
      throw;
    }
    if (!offered(offers, key)) {  // with an offer list, the operator's list wins
      spdlog::info("server: ladder rung {} is not offered (--tiers): left out", t);
      continue;
    }
    ladder.rungs.push_back(std::move(key));
    if (sized) ladder.sizes.push_back(config.ladder_sizes[i]);
  }
  return ladder;
}

void allowed_rungs(const Ladder& ladder, const ViewerFloor& floor, std::span<const double> measured,
                   int64_t now_us, std::vector<char>& ok, bool cap) {
  ok.assign(ladder.rungs.size(), 0);
  const auto decodes = [&floor](const std::string& codec) {
    return floor.decodes.empty() ||
           std::find(floor.decodes.begin(), floor.decodes.end(), codec) != floor.decodes.end();
  };
  for (size_t r = floor.top; r < ladder.rungs.size(); ++r) {
    const Tier& k = ladder.rungs[r];
    if ((floor.adapt & protocol::Hello::kKeepLossless) && !depth_codec_info(k.depth_codec).lossless)
      continue;
    if ((floor.adapt & protocol::Hello::kKeepFullRate) && k.frame_divisor > 1) continue;
    if (!decodes(k.depth_codec) || !decodes(k.color_codec)) continue;  // never, floors or not
    if (r < floor.refused_until.size() && floor.refused_until[r] > now_us) continue;
    const double bits = r < measured.size() ? measured[r] : 0;
    if (cap && floor.max_bits_per_s > 0 && bits > double(floor.max_bits_per_s)) continue;
    ok[r] = 1;
  }
}

void estimate_unmeasured(const Ladder& ladder, size_t current, std::span<double> bits) {
  const size_t known =
      current < bits.size() && bits[current] > 0
          ? current
          : size_t(std::find_if(bits.begin(), bits.end(), [](double b) { return b > 0; }) -
                   bits.begin());
  if (ladder.sizes.size() != bits.size() || known >= bits.size()) return;
  for (size_t r = 0; r < bits.size(); ++r)
    if (bits[r] <= 0) bits[r] = bits[known] * ladder.sizes[r] / ladder.sizes[known];
}

}  // namespace detail
}  // namespace volcast
