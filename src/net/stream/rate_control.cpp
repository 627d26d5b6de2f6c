#include "volcast/net/stream/rate_control.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace volcast {

RateController::RateController(size_t rungs, size_t start, RateControlConfig config)
    : config_(config),
      rungs_(std::max<size_t>(rungs, 1)),
      rung_(std::min(start, rungs_ - 1)),
      hold_us_(config.hold_us) {}

void RateController::trim(int64_t now_us) {
  const int64_t from = now_us - config_.window_us;
  // The last two Acks stay however old: a path slower than one frame set per window still has a
  // goodput.
  while (acked_.size() > 2 && acked_.front().time_us < from) acked_.pop_front();
  while (!skips_.empty() && skips_.front() < from) skips_.pop_front();
  while (!sent_.empty() && sent_.front().time_us < from) sent_.pop_front();
  queue_ms_ = acked_.empty() ? 0 : acked_.front().queue_ms;
  for (const Acked& a : acked_) queue_ms_ = std::min(queue_ms_, a.queue_ms);
}

void RateController::on_ack(int64_t now_us, size_t bytes, int64_t rtt_us, int64_t min_rtt_us) {
  if (window_start_us_ < 0) window_start_us_ = now_us;
  acked_.push_back({now_us, bytes, double(std::max<int64_t>(0, rtt_us - min_rtt_us)) / 1000,
                    double(bytes) * 8e6 / double(std::max<int64_t>(1, rtt_us))});
  trim(now_us);
}

void RateController::on_skip(int64_t now_us, uint64_t n) {
  if (window_start_us_ < 0) window_start_us_ = now_us;
  for (uint64_t i = 0; i < std::min<uint64_t>(n, 64); ++i) skips_.push_back(now_us);
  trim(now_us);
}

void RateController::on_send(int64_t now_us, bool drained) {
  if (window_start_us_ < 0) window_start_us_ = now_us;
  sent_.push_back({now_us, drained});
  trim(now_us);
}

bool RateController::app_limited() const {
  if (!skips_.empty() || sent_.size() < 2) return false;
  const auto drained =
      std::count_if(sent_.begin(), sent_.end(), [](const Sent& s) { return s.drained; });
  return drained >= 2 && 2 * size_t(drained) >= sent_.size();
}

bool RateController::room_for(double rate_bits, int64_t now_us) const {
  const int64_t from = now_us - config_.window_us;
  return std::any_of(acked_.begin(), acked_.end(), [&](const Acked& a) {
    return a.time_us >= from && a.rate_bits >= config_.room * rate_bits;
  });
}

double RateController::goodput_bits(int64_t now_us) const {
  if (acked_.size() < 2 || window_start_us_ < 0) return 0;
  const int64_t from = now_us - config_.window_us;
  if (acked_[1].time_us < from) {  // fewer than two Acks in the window: since the older of the two
    const int64_t span = now_us - acked_[0].time_us;
    return span <= 0 ? 0 : double(acked_[1].bytes) * 8e6 / double(span);
  }
  size_t bytes = 0;
  for (const Acked& a : acked_)
    if (a.time_us >= from) bytes += a.bytes;
  const int64_t span = std::min(config_.window_us, now_us - window_start_us_);
  return span <= 0 ? 0 : double(bytes) * 8e6 / double(span);
}

double RateController::rate_of(size_t rung, std::span<const double> rate_bits) const {
  if (rung < rate_bits.size() && rate_bits[rung] > 0) return rate_bits[rung];
  for (size_t k = rung; k-- > 0;)  // the nearest better rung measured
    if (k < rate_bits.size() && rate_bits[k] > 0)
      return rate_bits[k] * std::pow(config_.unknown_ratio, double(rung - k));
  for (size_t k = rung + 1; k < rate_bits.size(); ++k)  // or the nearest worse one
    if (rate_bits[k] > 0) return rate_bits[k] / std::pow(config_.unknown_ratio, double(k - rung));
  return 0;
}

bool RateController::decide(int64_t now_us, std::span<const double> rate_bits,
                            std::span<const char> allowed, RateDecision& out) {
  if (window_start_us_ < 0) window_start_us_ = now_us;
  if (clear_since_ < 0) clear_since_ = now_us;
  trim(now_us);
  const auto ok = [&](size_t r) { return r < allowed.size() && allowed[r]; };
  const bool measured = now_us - window_start_us_ >= config_.window_us;
  const double rate = rate_of(rung_, rate_bits);
  const double good = goodput_bits(now_us);
  const bool deficit = measured && rate > 0 && good < config_.deficit * rate && !app_limited() &&
                       !room_for(rate, now_us);
  const bool queue = queue_ms_ > config_.queue_ms;
  const bool skips = static_cast<int>(skips_.size()) >= config_.min_skips;
  if (deficit && (queue || skips)) {
    if (congested_since_ < 0) congested_since_ = now_us;
    clear_since_ = now_us;
  } else {
    congested_since_ = -1;
  }
  if (congested_since_ >= 0 && now_us - congested_since_ >= config_.congest_us) {
    const std::string why = fmt::format(
        "the path delivers {:.1f} Mbit/s (queue {:.0f} ms, {} frame sets missed in "
        "{:.1f} s) where this tier needs {:.1f} Mbit/s",
        good / 1e6, queue_ms_, skips_.size(), double(config_.window_us) / 1e6, rate / 1e6);
    // The best rung below that fits in `fill` x goodput; else the worst one allowed below.
    size_t target = rungs_, worst = rungs_;
    for (size_t r = rung_ + 1; r < rungs_; ++r) {
      if (!ok(r)) continue;
      worst = r;
      if (target == rungs_ && rate_of(r, rate_bits) <= config_.fill * good) target = r;
    }
    if (target == rungs_) target = worst;
    if (target == rungs_ || target == rung_) {
      if (last_notice_ >= 0 && now_us - last_notice_ < hold_us_) return false;
      last_notice_ = now_us;
      congested_since_ = now_us;
      out = {rung_, true, false, why};
      return true;
    }
    if (probe_until_ >= now_us) hold_us_ = std::min(hold_us_ * 2, config_.max_hold_us);
    out = {target, false, false, why};
    return true;
  }
  if (probe_until_ >= 0 && now_us > probe_until_) {  // the last probe held
    hold_us_ = config_.hold_us;
    probe_until_ = -1;
  }
  if (congested_since_ < 0 && rung_ > 0 && now_us - clear_since_ >= hold_us_ &&
      queue_ms_ < config_.queue_ms) {
    for (size_t r = rung_; r-- > 0;) {
      if (!ok(r)) continue;
      out = {r, false, true,
             fmt::format("clear for {:.0f} s at {:.1f} Mbit/s (queue {:.0f} ms): probing a better "
                         "tier",
                         double(now_us - clear_since_) / 1e6, good / 1e6, queue_ms_)};
      return true;
    }
  }
  return false;
}

void RateController::switched(size_t rung, int64_t now_us, bool up) {
  rung_ = std::min(rung, rungs_ - 1);
  acked_.clear();
  skips_.clear();
  sent_.clear();
  window_start_us_ = now_us;
  congested_since_ = -1;
  clear_since_ = now_us;
  probe_until_ = up ? now_us + config_.probe_us : -1;
}

}  // namespace volcast
