#include "volcast/net/stream/pacing.hpp"

#include <algorithm>
#include <cmath>

namespace volcast {
namespace {
constexpr int64_t kRttWindowUs = 10'000'000;
constexpr int64_t kRateWindowUs = 2'000'000;
}  // namespace

Pacer::Pacer(int max_window, double gain) : max_window_(std::max(1, max_window)), gain_(gain) {}

double Pacer::allowance_bytes() const {
  // `gain` bandwidth-delay products: headroom for an app-limited estimate to grow, and for TCP's
  // loss recovery on a lossy path.
  return gain_ * bottleneck_bytes_per_us() * min_rtt_us();
}

bool Pacer::can_send(size_t bytes) const {
  if (flight_.empty()) return true;
  if (flight_.size() >= static_cast<size_t>(max_window_)) return false;
  if (rtt_.empty()) return flight_.size() < 2;
  return static_cast<double>(bytes_in_flight_ + bytes) <= allowance_bytes();
}

int Pacer::window_frames() const {
  if (rtt_.empty() || mean_frame_bytes_ <= 0) return std::min(2, max_window_);
  const double frames = std::floor(allowance_bytes() / mean_frame_bytes_);
  return static_cast<int>(std::clamp(frames, 1.0, static_cast<double>(max_window_)));
}

void Pacer::on_send(uint64_t sequence, size_t bytes, int64_t now_us) {
  flight_.push_back({sequence, now_us, bytes, delivered_, delivered_us_});
  bytes_in_flight_ += bytes;
  const double b = static_cast<double>(bytes);
  mean_frame_bytes_ = mean_frame_bytes_ == 0 ? b : 0.9 * mean_frame_bytes_ + 0.1 * b;
}

bool Pacer::on_ack(uint64_t sequence, int64_t now_us) {
  const auto it = std::find_if(flight_.begin(), flight_.end(),
                               [&](const Sent& s) { return s.sequence == sequence; });
  if (it == flight_.end()) return false;
  const Sent sent = *it;
  flight_.erase(it);
  bytes_in_flight_ -= sent.bytes;
  delivered_ += sent.bytes;
  // Delivery rate over the interval since the last Ack seen when this frame set was sent (or
  // since it was sent, for the first): what the path delivered while it was in flight.
  const int64_t since = sent.delivered_us_at_send > 0 ? sent.delivered_us_at_send : sent.send_us;
  const int64_t interval = std::max<int64_t>(1, now_us - since);
  const double rate =
      static_cast<double>(delivered_ - sent.delivered_at_send) / static_cast<double>(interval);
  delivered_us_ = now_us;
  const int64_t rtt = std::max<int64_t>(1, now_us - sent.send_us);
  last_rtt_us_ = rtt;
  last_acked_bytes_ = sent.bytes;

  while (!rtt_.empty() && rtt_.back().value >= rtt) rtt_.pop_back();
  rtt_.push_back({now_us, rtt});
  while (rtt_.front().time_us < now_us - kRttWindowUs) rtt_.pop_front();
  while (!rate_.empty() && rate_.back().value <= rate) rate_.pop_back();
  rate_.push_back({now_us, rate});
  while (rate_.front().time_us < now_us - kRateWindowUs) rate_.pop_front();
  return true;
}

}  // namespace volcast
