#pragma once
// A Server's encoded tiers and its Welcome, published on a NATS cluster (issue 17): one encoding
// per tier, shared by the server's own viewers and every NATS subscriber, and made only while a
// subscriber says it wants the tier (TierInterest, on nats.hpp's want subject).
#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "volcast/cluster/nats.hpp"
#include "volcast/net/protocol/protocol.hpp"
#include "volcast/net/stream/server.hpp"

namespace volcast::cluster {

struct PublisherStats {
  uint64_t frame_sets = 0;  ///< published (all tiers)
  uint64_t chunks = 0;      ///< messages those took
  uint64_t bytes = 0;       ///< body bytes published
  uint64_t welcomes = 0;
  uint64_t errors = 0;        ///< publishes that failed (the NATS link was down): frame sets lost
  uint64_t starts = 0;        ///< times a published tier began because a subscriber wanted it
  uint64_t stops = 0;         ///< times one stopped because nobody wanted it any more
  uint64_t key_requests = 0;  ///< key frame sets subscribers asked for
  std::string last_error;
};

class TierPublisher {
 public:
  /// Publishes `welcome` on welcome_subject(site) now and every `welcome_interval_ms` after (a
  /// subscriber that comes later has it within that), on its own thread. A published tier with no
  /// want for `want_timeout_ms` stops. Throws Error for a site name that is no subject token.
  TierPublisher(NatsConnection& nats, std::string site, protocol::Welcome welcome,
                int welcome_interval_ms = 1000, int want_timeout_ms = 3000);
  ~TierPublisher();  ///< stops the Welcome thread and the wants; stop the server first
  TierPublisher(const TierPublisher&) = delete;
  TierPublisher& operator=(const TierPublisher&) = delete;

  /// Offers `server`'s tier on tier_subject(): while a subscriber wants it (want_subject, every
  /// second), the tier is tapped (encoded for nobody else if need be) and each of its frame sets
  /// published, chunked below the NATS server's max_payload (chunks.hpp), from its next key
  /// frame set on; a want with bit 0 set asks the tier for a key frame set. A failed publish is
  /// counted (stats().errors), never thrown into the server. Throws Error for codec names that
  /// are no subject tokens, or if the want subscription is refused.
  void publish_tier(Server& server, const Tier& tier);

  PublisherStats stats() const;

 private:
  struct Offered {
    Server* server = nullptr;
    Tier tier;
    std::string subject;
    uint64_t tap = 0;  // the server's tap while wanted, else 0
    std::chrono::steady_clock::time_point wanted;
  };
  void publish_welcome();
  void on_want(size_t tier, std::span<const uint8_t> data);
  void expire_wants();
  NatsConnection& nats_;
  std::string site_;
  std::vector<uint8_t> welcome_;
  int want_timeout_ms_;
  mutable std::mutex mutex_;  // stats_, and one tier's publish at a time (the scratch buffer)
  PublisherStats stats_;
  std::vector<uint8_t> scratch_;
  std::mutex demand_mutex_;  // offered_ (never held with mutex_ taken after it, nor by a tap)
  std::vector<Offered> offered_;
  std::vector<std::unique_ptr<NatsConnection::Subscription>> wants_;
  std::atomic<bool> stop_{false};
  std::thread welcome_thread_;
};

/// A subscriber's half of publishing on demand: says on want_subject() every `interval_ms` that it
/// wants the tier (the first time at once, asking for a key frame set), on its own thread, until
/// destroyed. A publish that fails (the link is down) is tried again at the next interval.
class TierInterest {
 public:
  /// Throws Error for names that are no subject tokens.
  TierInterest(NatsConnection& nats, const std::string& site, const Tier& tier,
               int interval_ms = 1000);
  ~TierInterest();
  TierInterest(const TierInterest&) = delete;
  TierInterest& operator=(const TierInterest&) = delete;
  /// Asks the publisher for a key frame set now (at most every 250 ms; more often is ignored).
  void request_key();

 private:
  void say(bool key);
  NatsConnection& nats_;
  std::string subject_;
  std::mutex mutex_;
  std::chrono::steady_clock::time_point last_key_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace volcast::cluster
