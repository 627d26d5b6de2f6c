#pragma once
// A Server's encoded tiers and its Welcome, published on a NATS cluster (issue 17, part 1): one
// encoding per tier, shared by the server's own viewers and every NATS subscriber.
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "volcast/cluster/nats.hpp"
#include "volcast/net/protocol.hpp"
#include "volcast/net/server.hpp"

namespace volcast::cluster {

struct PublisherStats {
  uint64_t frame_sets = 0;  ///< published (all tiers)
  uint64_t chunks = 0;      ///< messages those took
  uint64_t bytes = 0;       ///< body bytes published
  uint64_t welcomes = 0;
  uint64_t errors = 0;  ///< publishes that failed (the NATS link was down): frame sets lost
  std::string last_error;
};

class TierPublisher {
 public:
  /// Publishes `welcome` on welcome_subject(site) now and every `welcome_interval_ms` after (a
  /// subscriber that comes later has it within that), on its own thread. Throws Error for a site
  /// name that is no subject token.
  TierPublisher(NatsConnection& nats, std::string site, protocol::Welcome welcome,
                int welcome_interval_ms = 1000);
  ~TierPublisher();  ///< stops the Welcome thread; detach the taps first (stop the server)
  TierPublisher(const TierPublisher&) = delete;
  TierPublisher& operator=(const TierPublisher&) = delete;

  /// Taps `server`'s tier and publishes each of its frame sets on tier_subject(), chunked below
  /// the server's max_payload (chunks.hpp). The tier is encoded from its next key frame set on,
  /// as for a recorder. A failed publish is counted (stats().errors), never thrown into the
  /// server. Throws Error for codec names that are no subject tokens.
  void publish_tier(Server& server, const std::string& depth_codec, const std::string& color_codec,
                    int color_quality);

  PublisherStats stats() const;

 private:
  void publish_welcome();
  NatsConnection& nats_;
  std::string site_;
  std::vector<uint8_t> welcome_;
  mutable std::mutex mutex_;  // stats_, and one tier's publish at a time (the scratch buffer)
  PublisherStats stats_;
  std::vector<uint8_t> scratch_;
  std::atomic<bool> stop_{false};
  std::thread welcome_thread_;
};

}  // namespace volcast::cluster
