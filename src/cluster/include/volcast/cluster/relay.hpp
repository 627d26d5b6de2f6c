#pragma once
// A relay: a site's stream taken from a NATS cluster and served to native and web viewers exactly
// as the site's own server serves them (same TLS, join token, pacing and drop behaviour; issue 17,
// part 2). Any number of relays, on any machines, take the same published tier; a viewer needs
// nothing but the relay's link.
//
// The relay waits for the site's Welcome (nats.hpp: volcast.<site>.welcome), starts a Server for
// its cameras, and subscribes to one published tier. Each frame set put back together from its
// chunks (chunks.hpp) is published to the Server with its encoded body attached: viewers of the
// published tier are sent the publisher's bytes (server.hpp pass-through: bit-exact, no second
// encoding); capture times are the site's, so their latency figures run from the site's capture.
// A frame set is decoded only when images are needed: a temporal tier (its decoders follow every
// frame set, and a joining viewer's key frame set is made here from them), or a viewer on another
// tier, which the relay encodes itself. While every viewer takes the published stateless tier
// nothing is decoded, and the last decoded images stand in for a tier that begins meanwhile. The
// relay says it wants the tier (TierInterest) for as long as it runs, so the site publishes it,
// and asks for a key frame set when it starts and whenever it lost a delta. A
// relay whose NATS link drops keeps its viewers (libnats reconnects); the stream resumes with the
// next frame set a viewer can decode (any frame set of a stateless tier, else the next key frame
// set). Session messages of the relay's viewers go to the site's hub (session_link.hpp): a
// participant may join the site's sessions through any relay.
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>

#include "volcast/cluster/chunks.hpp"
#include "volcast/cluster/nats.hpp"
#include "volcast/cluster/session_link.hpp"
#include "volcast/cluster/tier_publisher.hpp"
#include "volcast/codec/tier.hpp"
#include "volcast/core/frame_pool.hpp"
#include "volcast/net/protocol/frame_set.hpp"
#include "volcast/net/protocol/protocol.hpp"
#include "volcast/net/stream/server.hpp"

namespace volcast::cluster {

struct RelayOptions {
  std::string site = "or";  ///< the site's subject token (TierPublisher's)
  /// The published tier taken from NATS (quality 0: the codec default). Viewers asking for it get
  /// the publisher's bytes; other tiers are encoded here from the decoded frames.
  Tier tier{"volcast", "jpeg"};
  int welcome_timeout_ms = 10000;  ///< give up unless the site's Welcome arrives this soon
  /// The virtual OR's session: viewers' session messages go to the site's hub and back
  /// (session_link.hpp), so they join the site's sessions through this relay. Off: they are
  /// read and skipped (server.session stays as given).
  bool session = true;
  std::string relay_name;  ///< this relay's subject token for the session (empty: a random one)
  ServerConfig server;     ///< the relay's own server (port, TLS, token, web page, ...)
};

struct RelayStats {
  uint64_t frame_sets = 0;       ///< published to the relay's server
  uint64_t decoded = 0;          ///< of those, decoded (need_images: a temporal tier, another tier)
  uint64_t undecodable = 0;      ///< dropped: corrupt, or a delta with no frame set before it
  uint64_t welcome_changes = 0;  ///< Welcomes naming other cameras than the relay serves (ignored)
  ReassemblyStats chunks;    ///< what came in (malformed chunks, abandoned frame sets, restarts)
  int64_t nats_dropped = 0;  ///< messages libnats dropped: the relay fell behind
  std::string last_error;
};

class Relay {
 public:
  /// Subscribes to the site's Welcome on `nats` and waits for it (at most welcome_timeout_ms),
  /// starts the server for its cameras and subscribes to the tier. Throws Error naming the site
  /// and subject when no Welcome comes, or what the Server or NATS refused (a codec this build
  /// lacks, a port in use, permissions). `nats` must outlive the Relay.
  Relay(NatsConnection& nats, RelayOptions options);
  ~Relay();  ///< unsubscribes, then stops the server (its viewers are disconnected)
  Relay(const Relay&) = delete;
  Relay& operator=(const Relay&) = delete;

  Server& server() { return *server_; }
  /// The site's cameras as its Welcome named them.
  const std::vector<protocol::CameraInfo>& cameras() const { return cameras_; }
  RelayStats stats() const;
  /// The session link to the site's hub; null when RelayOptions::session is off.
  const SessionForwarder* session() const { return session_.get(); }

 private:
  void on_welcome(std::span<const uint8_t> data);
  void on_chunk(std::span<const uint8_t> data);
  void relay(const ChunkedFrameSet& f);
  // Whether this frame set must be decoded: a temporal tier (its decoders follow every frame
  // set), a tier the relay encodes itself, or no images yet.
  bool need_images() const;

  NatsConnection& nats_;
  RelayOptions options_;
  mutable std::mutex mutex_;  // the fields below
  std::condition_variable welcomed_;
  std::vector<protocol::CameraInfo> cameras_;
  std::vector<uint8_t> cameras_bytes_;  // the Welcome's camera list as serialized, for comparison
  RelayStats stats_;
  // The tier's thread (libnats' callback for the tier subscription) owns these.
  std::unique_ptr<Reassembler> reassembler_;  // sized for the Welcome's cameras
  std::unique_ptr<FrameSetDecoder> decoder_;
  std::unique_ptr<FramePool> pool_;
  FrameSet decoded_;
  std::vector<uint8_t> message_;  // 8 bytes for a send time, then the body
  protocol::FrameSetView view_;   // of message_
  bool have_previous_ = false;    // the decoders hold the frame set before the next one
  uint64_t previous_ = 0;         // its number (ChunkedFrameSet::sequence)
  uint64_t published_ = 0;
  std::vector<std::shared_ptr<const CameraFrame>> last_images_;  // the last frame set decoded
  std::unique_ptr<SessionForwarder> session_;  // outlives server_, whose SessionPort it is
  std::unique_ptr<Server> server_;
  std::unique_ptr<NatsConnection::Subscription> welcome_sub_, tier_sub_;
  std::unique_ptr<TierInterest> interest_;  // tells the site the tier is wanted
};

}  // namespace volcast::cluster
