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

namespace {
constexpr int64_t kRefusedForUs = 10'000'000;  // a rung the budget refused is left out this long
constexpr size_t kSwitchesKept = 64;
}  // namespace

double Server::Impl::tier_bits(const Tier& key) const {
  for (const auto& t : tiers)
    if (!t->stop && t->encoder.key() == key && t->report.mbit_s > 0) return t->report.mbit_s * 1e6;
  const auto it = ladder.learned_bits.find(to_string(key));
  return it == ladder.learned_bits.end() ? 0 : it->second;
}

void Server::Impl::ladder_bits(std::vector<double>& bits) const {
  bits.resize(ladder.rungs.size());
  for (size_t r = 0; r < ladder.rungs.size(); ++r) bits[r] = tier_bits(ladder.rungs[r]);
}

int Server::Impl::rung_of(const Viewer& v) const {
  for (size_t r = 0; r < ladder.rungs.size(); ++r)
    if (v.tier && v.tier->encoder.key() == ladder.rungs[r]) return static_cast<int>(r);
  return -1;
}

std::shared_ptr<Server::Impl::Producer> Server::Impl::subscribe_adaptive(Viewer& v) {
  const std::vector<Tier>& rungs = ladder.rungs;
  v.floor.refused_until.assign(rungs.size(), 0);
  v.floor.top = 0;
  for (size_t r = 0; r < rungs.size(); ++r)
    if (rungs[r] == v.floor.hello_tier) v.floor.top = r;
  const int64_t now = steady_us();
  std::vector<double> bits;
  ladder_bits(bits);
  std::vector<char> ok;
  detail::allowed_rungs(ladder, v.floor, bits, now, ok);
  if (std::find(ok.begin(), ok.end(), 1) == ok.end()) {
    // Floors and cap leave nothing: the viewer's floor wins over its cap (a lossless viewer is
    // never given lossy depth); it starts on the lightest rung its floors allow.
    detail::allowed_rungs(ladder, v.floor, bits, now, ok, false);
    std::reverse(ok.begin(), ok.end());  // the lightest first
    std::vector<char> lightest(ok.size(), 0);
    if (const auto it = std::find(ok.begin(), ok.end(), 1); it != ok.end())
      lightest[ok.size() - 1 - size_t(it - ok.begin())] = 1;
    ok = lightest;
  }
  std::optional<Error> first;
  for (size_t r = 0; r < rungs.size(); ++r) {
    if (!ok[r]) continue;
    try {
      return subscribe(rungs[r], &v.wake, &v.address, false);
    } catch (const Error& e) {
      v.floor.refused_until[r] = now + kRefusedForUs;
      if (!first) first = e;
    }
  }
  if (first) throw *first;
  throw Error(
      "no tier of this server's ladder keeps your floor (lossless depth or full frame rate): "
      "ask for another floor");
}

void Server::Impl::send_tier_change(Viewer& v, const std::string& reason, double goodput_bits) {
  const Tier& k = v.tier->encoder.key();
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
    const std::string reason = "staying on " + from + " (" +
                               ((v.floor.adapt & protocol::Hello::kAdapt)
                                    ? std::string("the lightest tier your floor allows")
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
    const Tier& key = ladder.rungs[d.rung];
    // Off its tier while the budget is checked: the tier it leaves costs nothing once it has no
    // viewer.
    std::shared_ptr<Producer> old = std::move(v.tier);
    std::erase(old->subscribers, &v.wake);
    try {
      v.tier = subscribe(key, &v.wake, &v.address, false);
    } catch (const Error& e) {
      v.tier = std::move(old);
      v.tier->subscribers.push_back(&v.wake);  // stays where it was
      v.floor.refused_until[d.rung] = now + kRefusedForUs;
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
