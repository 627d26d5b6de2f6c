// The Server's tiers: one encoding thread each, the CPU budget a new tier must fit, and who
// watches which (server_impl.hpp).
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>

#include "server_impl.hpp"
#include "volcast/core/error.hpp"

namespace volcast {

// Called by publish() with mutex held: notes the time and updates peak_fps, the highest rate
// seen in the last 30 s, so that a publisher slowed for a while by a busy machine does not make
// the tiers look cheap. The rate is the mean over the last 33 publish() calls (once they span
// 1 s or are 33): a publisher that catches up in bursts (a replay woken late) publishes at its
// mean rate, where the median gap between its frame sets (0 inside a burst) made it look 1000 fps.
void Server::Impl::note_published() {
  const int64_t now = steady_us();
  published_us.push_back(now);
  if (published_us.size() > 33) published_us.pop_front();
  const int64_t span_us = now - published_us.front();
  if (published_us.size() < 3 || (span_us < 1'000'000 && published_us.size() < 33)) return;
  const double fps = std::clamp(
      double(published_us.size() - 1) * 1e6 / double(std::max<int64_t>(span_us, 1)), 1.0, 1000.0);
  if (fps >= peak_fps || now - peak_us > 30'000'000) {
    peak_fps = fps;
    peak_us = now;
  }
}

// Whether the viewers of `address` are all that watch `tier` (no other address, no tap).
bool Server::Impl::held_alone_by(const Tier& tier, const std::string& address) const {
  if (!tier.taps.empty()) return false;
  bool any = false;
  for (const auto& v : viewers) {
    if (v.done || v.tier.get() != &tier) continue;
    if (v.address != address) return false;
    any = true;
  }
  return any;
}

// Throws Error if a new tier `key` costing `encode_ns` per frame set would take the tiers past
// the CPU budget, or the tiers `address` holds alone past its share (the count, half the
// budget). The costliest tiers are the first not to fit. Caller holds mutex.
void Server::Impl::check_tier_budget(const volcast::Tier& key, double encode_ns,
                                     const std::string& address, bool share) const {
  const double fps = site_fps();
  const double cost = encode_ns * fps / 1e9;
  double total = 0, alone = 0;
  int alone_count = 0;
  for (const auto& t : tiers) {
    // A tier nobody watches or taps encodes nothing (and is reaped): a viewer switching away
    // from its tier does not pay for it.
    if (t->stop || (t->subscribers.empty() && t->taps.empty())) continue;
    const double c = t->encode_ns * fps / 1e9;
    total += c;
    if (held_alone_by(*t, address)) {
      alone += c;
      ++alone_count;
    }
  }
  const std::string name = to_string(key);
  // Each reason fits the 200 characters a viewer shows of a Reject.
  if (total + cost > budget_cores)
    throw Error(fmt::format(
        "tier {} would cost about {:.2f} CPU cores; the tiers' budget is {:.2f} cores "
        "(--tier-cpu-budget), {:.2f} in use: choose cheaper codecs or a tier already watched",
        name, cost, budget_cores, total));
  if (!share) return;
  if (alone_count >= config.max_tiers_per_address)
    throw Error(
        fmt::format("your address holds {} tiers nobody else watches, the most per address "
                    "(--max-tiers-per-address): choose the codecs of a viewer already watching",
                    alone_count));
  if (alone + cost > budget_cores / 2)
    throw Error(fmt::format(
        "tier {} would cost about {:.2f} CPU cores; your address's own tiers use {:.2f} of its "
        "share, {:.2f} cores (half the --tier-cpu-budget): choose cheaper codecs",
        name, cost, alone, budget_cores / 2));
}

// Joins the threads of viewers that have ended (keeping their reports) and of tiers nobody
// watches any more. Caller holds mutex (a finished viewer thread no longer takes it; a tier
// thread told to stop leaves without taking it).
void Server::Impl::reap_finished() {
  for (auto it = viewers.begin(); it != viewers.end();) {
    if (!it->done) {
      ++it;
      continue;
    }
    if (it->thread.joinable()) it->thread.join();
    ended.push_back(it->report);
    if (ended.size() > kEndedReportsKept) ended.pop_front();
    it = viewers.erase(it);
  }
  for (auto it = tiers.begin(); it != tiers.end();) {
    if (!(*it)->subscribers.empty() || !(*it)->taps.empty()) {
      ++it;
      continue;
    }
    (*it)->stop = true;
    retired.push_back(std::move((*it)->thread));
    it = tiers.erase(it);
  }
  captured_changed.notify_all();
}

// Joins the threads of stopped tiers. Caller must not hold mutex.
void Server::Impl::join_retired() {
  std::vector<std::thread> threads;
  {
    std::lock_guard lock(mutex);
    threads.swap(retired);
  }
  for (auto& t : threads) t.join();
}

// The tier's thread: encodes the newest frame set whenever there is one it has not encoded.
void Server::Impl::run_tier(std::shared_ptr<Tier> tier) {
  uint64_t last_sequence = 0, since_key = 0;
  auto last_key = std::chrono::steady_clock::now() - std::chrono::hours(1);
  while (true) {
    std::shared_ptr<const CapturedFrameSet> frames;
    bool key = false, seal = false;
    {
      std::unique_lock lock(mutex);
      captured_changed.wait(lock, [&] {
        return stopping || tier->stop || (captured && captured->sequence > last_sequence);
      });
      if (stopping || tier->stop) break;
      if (tier->subscribers.empty() &&
          tier->taps.empty()) {  // nobody: encode nothing until reaped or rejoined
        last_sequence = captured->sequence;
        continue;
      }
      frames = captured;
      // Over TLS and for enough viewers, sealed once here rather than encrypted once per viewer.
      seal = !config.insecure &&
             static_cast<int>(tier->subscribers.size()) >= config.seal_from_viewers;
      const auto now = std::chrono::steady_clock::now();
      // A replayed frame set recorded on this tier brings its own key frame sets: passing its
      // deltas through beats making keys on schedule.
      const EncodedFrameSetBody* pre = frames->encoded.get();
      const volcast::Tier& tk = tier->encoder.key();
      // A tier that encodes every Nth frame set waits for the next whose sequence N divides.
      if (tk.frame_divisor > 1 && frames->sequence % uint64_t(tk.frame_divisor) != 0) {
        last_sequence = frames->sequence;
        continue;
      }
      const bool recorded_tier =
          pre && tk.frame_divisor == 1 && pre->depth_codec == tk.depth_codec &&
          pre->color_codec == tk.color_codec && pre->color_quality == tk.color_quality;
      // Images standing in for a frame set not decoded (a relay's) are an earlier one's: a tier
      // encoded from images waits for the next, rather than stamp them with this one's time.
      if (frames->images_stale && !recorded_tier) {
        last_sequence = frames->sequence;
        continue;
      }
      key = tier->report.frames_encoded == 0 ||
            (!recorded_tier && since_key + 1 >= static_cast<uint64_t>(config.key_frame_interval)) ||
            (tier->key_wanted &&
             now - last_key >= std::chrono::milliseconds(config.min_key_interval_ms));
    }
    last_sequence = frames->sequence;
    const auto start = std::chrono::steady_clock::now();
    std::shared_ptr<const detail::EncodedFrames> encoded;
    try {
      encoded = tier->encoder.encode(*frames, key, *pool, seal);
    } catch (const std::exception& e) {
      spdlog::error("tier {}: frame set {} not encoded: {}", to_string(tier->report.tier),
                    frames->sequence, e.what());
      continue;
    }
    const auto end = std::chrono::steady_clock::now();
    std::unique_lock lock(mutex);
    if (encoded->key) {
      since_key = 0;
      last_key = end;
      tier->key_wanted = false;
      ++tier->report.key_frames;
    } else {
      ++since_key;
    }
    ++tier->report.frames_encoded;
    tier->encode_ms_total += std::chrono::duration<double, std::milli>(end - start).count();
    const double weight = 1.0 / double(std::min<uint64_t>(tier->report.frames_encoded, 30));
    tier->cpu_ms_mean += (tier->encoder.last_cpu_ms() - tier->cpu_ms_mean) * weight;
    tier->latest = encoded;
    // Its rate over the last second, for the viewers' rate control (learned for when it stops).
    const int64_t now_us = steady_us();
    tier->produced.emplace_back(now_us, encoded->body.size());
    while (tier->produced.front().first < now_us - 1'000'000) tier->produced.pop_front();
    if (now_us - tier->produced.front().first >= 500'000 || tier->produced.size() >= 8) {
      size_t bytes = 0;
      for (const auto& p : tier->produced) bytes += p.second;
      const double span_us = std::max<double>(double(now_us - tier->produced.front().first), 1) *
                             double(tier->produced.size()) /
                             double(std::max<size_t>(tier->produced.size() - 1, 1));
      tier->report.mbit_s = double(bytes) * 8 / span_us;
      learned_bits[to_string(tier->encoder.key())] = tier->report.mbit_s * 1e6;
    }
    for (const WakeFd* w : tier->subscribers) w->signal();
    if (tier->taps.empty()) continue;
    std::vector<std::shared_ptr<std::function<void(const TierFrameSet&)>>> taps;
    for (auto& tap : tier->taps) {
      tap.begun = tap.begun || encoded->key;
      if (tap.begun) taps.push_back(tap.fn);
    }
    lock.unlock();
    const TierFrameSet f{encoded->sequence, encoded->key, encoded->capture_us,
                         encoded->body,     encoded,      encoded->index};
    for (const auto& tap : taps) (*tap)(f);
  }
}

// Finds or makes the tier and subscribes `wake` (if not null) to it. A new tier for a viewer
// from `address` must fit the CPU budget (check_tier_budget); one for a tap (`address` null)
// is made regardless. Caller holds mutex. Throws Error.
std::shared_ptr<Server::Impl::Tier> Server::Impl::subscribe(const volcast::Tier& key,
                                                            const WakeFd* wake,
                                                            const std::string* address,
                                                            bool share) {
  std::shared_ptr<Tier> tier;
  for (const auto& t : tiers)
    if (t->encoder.key() == key && !t->stop) tier = t;
  if (!tier) {
    if (static_cast<int>(tiers.size()) >= config.max_tiers)
      throw Error("server has " + std::to_string(config.max_tiers) +
                  " tiers already; choose the codecs of a viewer already watching");
    // Unknown codecs throw; a tier of every Nth frame set costs 1/N per site frame set; the
    // publisher's own tier passes its bytes through (ServerConfig::passed_through_tier): free.
    const double estimate = detail::tier_encode_ns(key, site_pixels) / key.frame_divisor;
    const double encode_ns = passed_through == key ? 0 : estimate;
    if (address) check_tier_budget(key, encode_ns, *address, share);
    tier = std::make_shared<Tier>(key, cameras.size());
    tier->encode_ns = encode_ns;
    tier->report.tier = key;
    tiers.push_back(tier);
    tier->thread = std::thread([this, tier] { run_tier(tier); });
  }
  if (wake) tier->subscribers.push_back(wake);
  tier->key_wanted = true;  // the newcomer needs a key frame (a no-op for non-temporal tiers)
  return tier;
}

void Server::Impl::unsubscribe(Tier& tier, const WakeFd& wake) {
  std::lock_guard lock(mutex);
  std::erase(tier.subscribers, &wake);
}

}  // namespace volcast
