#pragma once
// Per-viewer pacing from Ack timing: how many frame sets may be in flight on this viewer's path.
// After BBR (N. Cardwell et al., "BBR: Congestion-Based Congestion Control", ACM Queue 14(5),
// 2016), at frame-set granularity: the round-trip time is the windowed minimum of send -> Ack
// (10 s; it includes a frame set's own transmission), the bottleneck rate the windowed maximum of
// delivery-rate samples (2 s), and the bytes in flight are kept under `gain` (2) x BDP, BDP = rate
// x round trip -- at least one frame set, at most `max_window`. The gain lets an app-limited
// estimate grow until the stream fits and rides out TCP's loss recovery; on a path slower than
// the stream about one BDP waits at the bottleneck (a viewer's tier then steps down:
// rate_control.hpp). Before the first Ack two frame sets may be in flight.
// All times are microseconds of one steady clock; sizes are bytes.
#include <cstddef>
#include <cstdint>
#include <deque>

namespace volcast {

class Pacer {
 public:
  explicit Pacer(int max_window, double gain = 2.0);

  /// True if a frame set of `bytes` may be sent now.
  bool can_send(size_t bytes) const;
  /// Frame set `sequence` of `bytes` sent; `now_us` (steady clock) when its write began: its
  /// round trip counts from there, never from a later clock reading.
  void on_send(uint64_t sequence, size_t bytes, int64_t now_us);
  /// Takes the Ack of `sequence`. Returns false (and changes nothing) if it is not in flight.
  bool on_ack(uint64_t sequence, int64_t now_us);

  size_t frames_in_flight() const { return flight_.size(); }
  /// 0 until the first Ack.
  double min_rtt_us() const { return rtt_.empty() ? 0 : static_cast<double>(rtt_.front().value); }
  /// Bytes per microsecond (= MB/s); 0 until the first Ack.
  double bottleneck_bytes_per_us() const { return rate_.empty() ? 0 : rate_.front().value; }
  /// Frame sets of the recent mean size that fit in the allowance now (1..max_window).
  int window_frames() const;
  /// The round trip (send -> Ack, µs) and bytes of the frame set on_ack() took last.
  int64_t last_rtt_us() const { return last_rtt_us_; }
  size_t last_acked_bytes() const { return last_acked_bytes_; }

 private:
  struct Sent {
    uint64_t sequence;
    int64_t send_us;
    size_t bytes;
    uint64_t delivered_at_send;  // bytes acknowledged when this was sent
    int64_t delivered_us_at_send;
  };
  template <typename T>
  struct Sample {
    int64_t time_us;
    T value;
  };
  double allowance_bytes() const;

  int max_window_;
  double gain_;
  std::deque<Sent> flight_;
  size_t bytes_in_flight_ = 0;
  uint64_t delivered_ = 0;
  int64_t delivered_us_ = 0;
  double mean_frame_bytes_ = 0;
  int64_t last_rtt_us_ = 0;
  size_t last_acked_bytes_ = 0;
  std::deque<Sample<int64_t>> rtt_;  // monotonic: front is the window's minimum
  std::deque<Sample<double>> rate_;  // monotonic: front is the window's maximum
};

}  // namespace volcast
