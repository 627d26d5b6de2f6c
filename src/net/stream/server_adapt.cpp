// The Server's rate adaptation: which ladder rung each adaptive viewer is on, and telling viewers
// of changes and of paths too slow for their floor (server.hpp, rate_control.hpp).
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>

#include "server_impl.hpp"
#include "volcast/codec/registry.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"

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

namespace {
constexpr int64_t kRefusedForUs = 10'000'000;  // a rung the budget refused is left out this long
constexpr size_t kSwitchesKept = 64;
}  // namespace

double Server::Impl::tier_bits(const volcast::Tier& key) const {
  for (const auto& t : tiers)
    if (!t->stop && t->encoder.key() == key && t->report.mbit_s > 0) return t->report.mbit_s * 1e6;
  const auto it = learned_bits.find(to_string(key));
  return it == learned_bits.end() ? 0 : it->second;
}

void Server::Impl::allowed_rungs(const Viewer& v, int64_t now, std::vector<char>& ok,
                                 bool cap) const {
  ok.assign(ladder.size(), 0);
  for (size_t r = v.top; r < ladder.size(); ++r) {
    const volcast::Tier& k = ladder[r];
    if ((v.adapt & protocol::Hello::kKeepLossless) && !depth_codec_info(k.depth_codec).lossless)
      continue;
    if ((v.adapt & protocol::Hello::kKeepFullRate) && k.frame_divisor > 1) continue;
    const auto decodes = [&v](const std::string& codec) {
      return v.decodes.empty() ||
             std::find(v.decodes.begin(), v.decodes.end(), codec) != v.decodes.end();
    };
    if (!decodes(k.depth_codec) || !decodes(k.color_codec)) continue;  // never, floors or not
    if (r < v.refused_until.size() && v.refused_until[r] > now) continue;
    const double bits = tier_bits(k);
    if (cap && v.max_bits_per_s > 0 && bits > double(v.max_bits_per_s)) continue;
    ok[r] = 1;
  }
}

int Server::Impl::rung_of(const Viewer& v) const {
  for (size_t r = 0; r < ladder.size(); ++r)
    if (v.tier && v.tier->encoder.key() == ladder[r]) return static_cast<int>(r);
  return -1;
}

std::shared_ptr<Server::Impl::Tier> Server::Impl::subscribe_adaptive(Viewer& v) {
  v.refused_until.assign(ladder.size(), 0);
  v.top = 0;
  for (size_t r = 0; r < ladder.size(); ++r)
    if (ladder[r] == v.hello_key) v.top = r;
  const int64_t now = steady_us();
  std::vector<char> ok;
  allowed_rungs(v, now, ok);
  if (std::find(ok.begin(), ok.end(), 1) == ok.end()) {
    // Floors and cap leave nothing: the viewer's floor wins over its cap (a lossless viewer is
    // never given lossy depth); it starts on the lightest rung its floors allow.
    allowed_rungs(v, now, ok, false);
    std::reverse(ok.begin(), ok.end());  // the lightest first
    std::vector<char> lightest(ok.size(), 0);
    if (const auto it = std::find(ok.begin(), ok.end(), 1); it != ok.end())
      lightest[ok.size() - 1 - size_t(it - ok.begin())] = 1;
    ok = lightest;
  }
  std::optional<Error> first;
  for (size_t r = 0; r < ladder.size(); ++r) {
    if (!ok[r]) continue;
    try {
      return subscribe(ladder[r], &v.wake, &v.address, false);
    } catch (const Error& e) {
      v.refused_until[r] = now + kRefusedForUs;
      if (!first) first = e;
    }
  }
  if (first) throw *first;
  throw Error(
      "no tier of this server's ladder keeps your floor (lossless depth or full frame rate): "
      "ask for another floor");
}

void Server::Impl::send_tier_change(Viewer& v, const std::string& reason, double goodput_bits) {
  const volcast::Tier& k = v.tier->encoder.key();
  protocol::TierChange m{k, static_cast<uint32_t>(std::clamp(goodput_bits / 1e3, 0.0, 4e9)),
                         reason};
  v.connection->write_all(protocol::message(protocol::MessageType::kTierChange, serialize(m)),
                          config.stall_timeout_ms);
}

bool Server::Impl::switch_tier(Viewer& v, const RateDecision& d, double goodput_bits) {
  const std::string from = to_string(v.tier->encoder.key());
  const auto record = [&](ViewerReport& r, const std::string& to, const std::string& reason) {
    r.switches.push_back({wall_clock_us(), from, to, reason});
    if (r.switches.size() > kSwitchesKept) r.switches.erase(r.switches.begin());
  };
  if (d.notice) {
    const std::string reason =
        "staying on " + from + " (" +
        ((v.adapt & protocol::Hello::kAdapt) ? std::string("the lightest tier your floor allows")
                                             : std::string("the tier you pinned")) +
        "): " + d.reason;
    update(v, [&](ViewerReport& r) { record(r, from, reason); });
    spdlog::info("viewer {}: {} -> {}: {}", v.report.peer, from, from, reason);
    send_tier_change(v, reason, goodput_bits);
    return true;
  }
  std::string to;
  {
    std::lock_guard lock(mutex);
    const int64_t now = steady_us();
    const volcast::Tier& key = ladder[d.rung];
    // Off its tier while the budget is checked: the tier it leaves costs nothing once it has no
    // viewer.
    std::shared_ptr<Tier> old = std::move(v.tier);
    std::erase(old->subscribers, &v.wake);
    try {
      v.tier = subscribe(key, &v.wake, &v.address, false);
    } catch (const Error& e) {
      v.tier = std::move(old);
      v.tier->subscribers.push_back(&v.wake);  // stays where it was
      v.refused_until[d.rung] = now + kRefusedForUs;
      spdlog::info("viewer {}: rung {} ({}) refused: {}", v.report.peer, d.rung, to_string(key),
                   e.what());
      return false;
    }
    v.report.tier = key;
    v.report.rung = static_cast<int>(d.rung);
    // In the same locked step as the rung: a report never shows a rung without its switch.
    to = to_string(key);
    record(v.report, to, d.reason);
  }
  spdlog::info("viewer {}: {} -> {}: {}", v.report.peer, from, to, d.reason);
  send_tier_change(v, d.reason, goodput_bits);
  return true;
}

}  // namespace volcast
