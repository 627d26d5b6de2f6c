#pragma once
// Per-participant rate limits of the session channel (issue 33, item 5), enforced where a message
// enters: the site's SessionHub for its own viewers and relays' viewers, and each relay's
// SessionForwarder before anything goes on NATS, one implementation for both. A token bucket per
// participant and message type: `burst` messages at once, refilled at `per_second`; a message
// finding the bucket empty is dropped (not forwarded, not applied) and its sender is not
// disconnected. A run of drops ("a burst": it ends after a second without one) is reported once
// when it starts, naming the limit, and with its count every 10 s while it lasts and once it has
// ended (at the sender's next message of that type, or when the sender goes): never per message.
//
// The limits (limit_of, message_table.cpp): what one real headset or desktop viewer sends, with
// room to spare.
//   poses 0x04, object moves 0x0b, monitor changes 0x0d   150 a second, 75 at once (display
//                                                          rate: 90-144 Hz headsets, monitors)
//   pose echoes 0x05     600 a second, 300 at once (every 6th pose of up to 15 others at 150 Hz)
//   avatar frames 0x08   30 a second, 15 at once (an RGB-D camera's 30 fps)
//   heartbeats 0x09      10 a second, 10 at once (2 Hz is sent)
//   grabs 0x0a, releases 0x0c   10 a second, 10 at once (a hand's)
//   teleports 0x06       4 a second, 8 at once
//   lobby: list 0x01, join 0x02, leave 0x03   2 a second, 5 at once
//   avatar camera 0x07   1 a second, 2 at once (sent once; twice is refused by the hub)
//   voice 0x0e           60 a second, 100 at once (50 a second while talking; after a stall
//                        of the sender's link or thread, the up to 50 its client held at once)
//   voice state 0x0f     5 a second, 10 at once (mute toggles)
// and the sessions one participant (one connection) may create (kSessionCreation): 4 at once,
// then one every 15 s.
#include <array>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>

#include "volcast/session/message_table.hpp"

namespace volcast::session {

/// The sessions one participant may create (Join with create, for a session not there yet).
inline constexpr RateLimit kSessionCreation{1.0 / 15, 4, "new sessions"};
/// "150 poses a second (75 at once)"
std::string to_string(const RateLimit& limit);

/// What RateLimiter::admit decided.
struct Admission {
  bool admitted = true;
  /// Non-empty when a burst of drops starts ("poses over the limit (poses: 75 at once, then 150
  /// a second): dropping them"), has ended, or has lasted another 10 s ("1234 poses dropped in
  /// 8.2 s over the limit (...)"): for the caller's log, and (when `started`) for the sender.
  std::string report;
  bool started = false;  ///< the report is a burst's first
};

/// Token buckets per (participant, message type), and per participant for session creation.
/// Thread-safe. Memory: one entry per participant seen, until forget().
class RateLimiter {
 public:
  /// A message of `type` from participant `who` at `now_us` (a steady clock, µs).
  Admission admit(uint64_t who, uint8_t type, int64_t now_us);
  /// A session created by `who` at `now_us`: kSessionCreation.
  Admission admit_creation(uint64_t who, int64_t now_us);
  /// `who` has gone (at `now_us`): its buckets are dropped. Returns the count of a burst in
  /// progress (empty if none), for the caller's log.
  std::string forget(uint64_t who, int64_t now_us);
  uint64_t dropped() const;  ///< messages dropped since it started, all participants

 private:
  struct Bucket {
    double tokens = -1;  // < 0: not used yet (starts full)
    int64_t last_us = 0, burst_since_us = 0, last_drop_us = 0, last_report_us = 0;
    uint64_t drops = 0;  // in the burst going on (0: none)
    RateLimit limit;
  };
  static constexpr size_t kSlots = 0x20 + 1;  // message types 0x00..0x1f, then creation
  Admission take(Bucket& b, const RateLimit& limit, int64_t now_us);
  static std::string burst_count(const Bucket& b, int64_t now_us);
  mutable std::mutex mutex_;
  std::map<uint64_t, std::array<Bucket, kSlots>> buckets_;
  uint64_t dropped_ = 0;
};

}  // namespace volcast::session
