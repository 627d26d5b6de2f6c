#pragma once
// Per-viewer rate adaptation: which rung of the server's tier ladder a viewer's path carries.
//
// The estimator, from the viewer's Acks (pacing.hpp sends frame sets; this only chooses what they
// are made of):
//  - goodput: bytes acknowledged in the last `window_us`, over that time -- BBR's delivery-rate
//    sample taken over a window (Cardwell et al., ACM Queue 2016), which on a path slower than the
//    stream is the bottleneck's rate;
//  - queueing delay: each Ack's round trip less the path's minimum (pacing.hpp), and of those the
//    smallest in the window -- a standing queue, as CoDel judges one (Nichols and Jacobson,
//    "Controlling Queue Delay", ACM Queue 2012: the minimum sojourn over an interval): a queue at
//    the bottleneck delays every Ack, while a late Ack now and then (a loaded viewer's or server's
//    scheduling, Wi-Fi retries) delays only itself and is not taken for a queue;
//  - skips: frame sets the pacer or the latency budget made this viewer miss.
// The path is *congested* while goodput is below `deficit` x the rung's rate AND (the queueing
// delay is over `queue_ms` OR it missed at least `min_skips` frame sets in the window): goodput
// below the stream's rate alone may be a site that encodes slowly; with a queue or skips it is the
// path. Congested for `congest_us` on end: step down at once to the best rung whose rate is at most
// `fill` x goodput (not one rung at a time: a path that halved is left within about one window).
// A window is *application-limited* -- BBR's app-limited delivery-rate samples (Cheng et al.,
// "Delivery Rate Estimation", IETF draft-cheng-iccrg-delivery-rate-estimation, 2.2) -- when
// nothing in it was missed and at least half its frame sets (two or more) went out with nothing
// in flight: the path had delivered everything before the site made more, so a goodput below the
// rung's rate is the site's (slow to start, loaded), and Acks late by the viewer's or server's
// scheduling are no queue. It is never congested. A path slower than the site cannot drain
// between frame sets without missing some, so it still steps down.
// A window also has *room* -- and is never congested -- when one of its Acks delivered its frame
// set at `room` x the rung's rate or faster: bytes over round trip is a lower bound of what the
// path carries (a frame set cannot cross a narrower bottleneck faster; BBR's delivery rate,
// Cardwell et al.), so frame sets held back or missed in it were held by a viewer that acknowledged
// late now and then (its thread on a loaded machine), not by the path. A viewer slow to decode,
// which acknowledges after decoding, has round trips as slow as its decoding and still steps down.
//
// Up, without oscillating: after `hold_us` without congestion (and a queue under `queue_ms`) it
// probes the next rung up. A probe that ends in congestion within `probe_us` steps back and doubles
// the hold (up to `max_hold_us`); one that lasts resets it. A path between two rungs is thus probed
// at 4, 8, 16, 32 s, ... -- the back-off of adaptive streaming's probing, bounded.
//
// Floors (the viewer's: lossless depth, full frame rate) and a cap (its max rate) make rungs
// unavailable; when congestion asks for a step below the lowest available one, decide() returns a
// notice instead (the same rung; the viewer is told why, at most once per hold).
//
// Rung rates are bits per second of frame sets (what the rung's tier produces, measured by the
// server while it runs; 0 = unknown, taken as `unknown_ratio` x the next better known one).
// Times are microseconds of one steady clock. Not thread-safe: one viewer's thread.
#include <cstddef>
#include <cstdint>
#include <deque>
#include <span>
#include <string>

namespace volcast {

struct RateControlConfig {
  int64_t window_us = 500'000;   ///< goodput and skip window
  double deficit = 0.85;         ///< goodput below this x the rung's rate: a deficit
  double queue_ms = 20;          ///< smoothed queueing delay above this: a queue
  int min_skips = 2;             ///< frame sets missed in the window: a queue's other sign
  double room = 1.0;             ///< an Ack at this x the rung's rate (bytes / round trip): room
  int64_t congest_us = 250'000;  ///< congested this long: step down
  double fill = 0.8;             ///< step down to a rung of at most this x goodput
  int64_t hold_us = 4'000'000;   ///< clear this long after a change: probe up
  int64_t max_hold_us = 32'000'000;
  int64_t probe_us = 3'000'000;  ///< a step up congested within this failed
  double unknown_ratio = 0.6;    ///< an unknown rung's rate: this x the better one's
};

struct RateDecision {
  size_t rung = 0;      ///< the rung to use (== the current one for a notice)
  bool notice = false;  ///< no change: the floor or pin keeps it on a rung the path cannot carry
  bool up = false;      ///< a probe up
  std::string reason;   ///< for people: what was measured
};

class RateController {
 public:
  /// `rungs` rungs, 0 the best; it starts on `start` (< rungs).
  RateController(size_t rungs, size_t start, RateControlConfig config = {});

  /// An Ack of `bytes` (a frame set) with round trip `rtt_us`; `min_rtt_us` the path's minimum.
  void on_ack(int64_t now_us, size_t bytes, int64_t rtt_us, int64_t min_rtt_us);
  /// `n` frame sets of the rung this viewer missed (pacing, latency budget).
  void on_skip(int64_t now_us, uint64_t n = 1);
  /// A frame set sent; `drained`: every frame set sent before it had been acknowledged.
  void on_send(int64_t now_us, bool drained);

  /// What to do now. `rate_bits` per rung (0: unknown); `allowed` per rung (a floor, the cap, a
  /// tier the server refused). Returns true and fills `out` when the rung should change or a
  /// notice is due; then call switched() (for a change) before the next call.
  bool decide(int64_t now_us, std::span<const double> rate_bits, std::span<const char> allowed,
              RateDecision& out);
  /// The viewer now gets rung `rung` (from its next key frame set): the window starts over.
  void switched(size_t rung, int64_t now_us, bool up);

  size_t rung() const { return rung_; }
  /// Bits per second acknowledged over the window; with fewer than 2 Acks in it, the newer of the
  /// last two over the time since the older (0 before 2 Acks).
  double goodput_bits(int64_t now_us) const;
  /// The standing queue: the smallest queueing delay of the Acks in the window, ms (0 before any).
  double queue_ms() const { return queue_ms_; }
  bool congested() const { return congested_since_ >= 0; }

 private:
  double rate_of(size_t rung, std::span<const double> rate_bits) const;
  void trim(int64_t now_us);

  RateControlConfig config_;
  size_t rungs_, rung_;
  struct Acked {
    int64_t time_us;
    size_t bytes;
    double queue_ms;   // its round trip less the path's minimum
    double rate_bits;  // its bytes over its round trip, bits per second
  };
  std::deque<Acked> acked_;
  std::deque<int64_t> skips_;
  struct Sent {
    int64_t time_us;
    bool drained;
  };
  std::deque<Sent> sent_;
  bool app_limited() const;
  bool room_for(double rate_bits, int64_t now_us) const;
  double queue_ms_ = 0;
  int64_t window_start_us_ = -1;  // when the current rung's measurements began
  int64_t congested_since_ = -1;
  int64_t clear_since_ = -1;  // last time it was congested, or the last change
  int64_t hold_us_;
  int64_t probe_until_ = -1;  // a probe up is on trial until then
  int64_t last_notice_ = -1;
};

}  // namespace volcast
