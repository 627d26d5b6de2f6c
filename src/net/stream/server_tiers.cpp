// The Server's tiers: one encoding thread each, the CPU budget a new tier must fit, and who
// watches which (server_impl.hpp).
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>

#include "server_impl.hpp"
#include "volcast/core/error.hpp"

namespace volcast {

// Whether the viewers of `address` are all that watch `tier` (no other address, no tap).
bool Server::Impl::held_alone_by(const Producer& tier, const std::string& address) const {
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
void Server::Impl::check_tier_budget(const Tier& key, double encode_ns, const std::string& address,
                                     bool share) const {
  detail::TierLoad load;
  for (const auto& t : tiers) {
    // A tier nobody watches or taps encodes nothing (and is reaped): a viewer switching away
    // from its tier does not pay for it.
    if (t->stop || t->idle()) continue;
    const double c = budget.cores_of(t->encode_ns);
    load.total += c;
    if (held_alone_by(*t, address)) {
      load.alone += c;
      ++load.alone_count;
    }
  }
  detail::check_tier_fits(budget, to_string(key), budget.cores_of(encode_ns), load,
                          config.max_tiers_per_address, share);
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
    if (!(*it)->idle()) {
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
void Server::Impl::run_tier(std::shared_ptr<Producer> tier) {
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
      if (tier->idle()) {  // nobody: encode nothing until reaped or rejoined
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
      const Tier& tk = tier->encoder.key();
      // A tier that encodes every Nth frame set waits for the next whose sequence N divides.
      if (tk.frame_divisor > 1 && frames->sequence % uint64_t(tk.frame_divisor) != 0) {
        last_sequence = frames->sequence;
        continue;
      }
      const bool recorded_tier = pre && pre->tier == tk;  // a recording's is of every frame set
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
    } else {
      ++since_key;
    }
    tier->latest = encoded;
    const double wall_ms = std::chrono::duration<double, std::milli>(end - start).count();
    if (tier->note_encoded(*encoded, wall_ms, steady_us()))  // learned for when it stops
      ladder.learned_bits[to_string(tier->encoder.key())] = tier->report.mbit_s * 1e6;
    for (const detail::WakeFd* w : tier->subscribers) w->signal();
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
std::shared_ptr<Server::Impl::Producer> Server::Impl::subscribe(const Tier& key,
                                                                const detail::WakeFd* wake,
                                                                const std::string* address,
                                                                bool share) {
  std::shared_ptr<Producer> tier;
  for (const auto& t : tiers)
    if (t->encoder.key() == key && !t->stop) tier = t;
  if (!tier) {
    if (static_cast<int>(tiers.size()) >= config.max_tiers)
      throw Error("server has " + std::to_string(config.max_tiers) +
                  " tiers already; choose the codecs of a viewer already watching");
    const double encode_ns = budget.encode_ns(key);  // unknown codecs throw
    if (address) check_tier_budget(key, encode_ns, *address, share);
    tier = std::make_shared<Producer>(key, cameras.size());
    tier->encode_ns = encode_ns;
    tier->report.tier = key;
    tiers.push_back(tier);
    tier->thread = std::thread([this, tier] { run_tier(tier); });
  }
  if (wake) tier->subscribers.push_back(wake);
  tier->key_wanted = true;  // the newcomer needs a key frame (a no-op for non-temporal tiers)
  return tier;
}

void Server::Impl::unsubscribe(Producer& tier, const detail::WakeFd& wake) {
  std::lock_guard lock(mutex);
  std::erase(tier.subscribers, &wake);
}

}  // namespace volcast
