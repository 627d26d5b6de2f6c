#pragma once
// The virtual OR's session through relays (issue 17, part 4): a participant may connect to any
// relay. The site's SessionHub stays the one arbiter (grabs in arrival order, presence, teleports
// checked against the room); each relay forwards its viewers' session messages to it over NATS
// and hands back what the hub sends them. The hub sees a relay's viewer as one of its own, with
// an id of its own (SessionHub::kRemoteViewer set), so everything a local participant gets — the
// case, the objects, the monitor, poses coalesced per sender, avatars — a relay's participant
// gets the same, byte for byte.
//
// Subjects (site and relay are subject tokens, nats.hpp):
//   volcast.<site>.session.up.<relay>     a relay's viewers' messages, to the site's hub
//   volcast.<site>.session.down.<relay>   the hub's messages for that relay's viewers
//
// Wire format of one NATS message ("a piece"), little-endian, kSessionPieceHeader bytes of header:
//    0  u8   kind: 1 = (a piece of) a session message; 2 = the viewer left (up) / disconnect it
//            (down), the bytes are the reason (UTF-8, at most kMaxSessionReason bytes, one piece)
//    1  u8   flags: 0 (reserved)
//    2  u8   type: up, the session message type (messages.hpp); down, 0 (the bytes are the whole
//            channel-2 message, header included, as Server::send_session takes it)
//    3  u8   0
//    4  u64  viewer: the relay's viewer id (Server's ViewerReport::id)
//   12  u64  coalesce key (down: Server::send_session's; up: 0)
//   20  u32  total: the message's size, bytes, in all its pieces
//   24  u32  offset of these bytes in the message
//   28  ...  bytes (at most the NATS server's max_payload - 28 per piece)
// A message is sent as consecutive pieces on one subject (offsets 0, n, 2n, ...); pieces of two
// messages never interleave on a subject. A receiver checks total against the message type's
// limit before it allocates anything, and drops a message whose pieces do not follow on.
#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "volcast/cluster/nats.hpp"
#include "volcast/net/stream/session_port.hpp"
#include "volcast/session/rate_limit.hpp"

namespace volcast::cluster {

inline constexpr size_t kSessionPieceHeader = 28;
inline constexpr size_t kMaxSessionReason = 1024;

std::string session_up_subject(const std::string& site, const std::string& relay);
std::string session_down_subject(const std::string& site, const std::string& relay);

enum class PieceKind : uint8_t { kMessage = 1, kLeft = 2 };

/// One piece's header (the wire format above).
struct SessionPiece {
  PieceKind kind = PieceKind::kMessage;
  uint8_t type = 0;
  uint64_t viewer = 0, coalesce_key = 0;
  uint32_t total = 0, offset = 0;
  std::span<const uint8_t> bytes;  ///< into the parsed message
};

/// Parses one NATS message. Throws Error naming the field for a short header, an unknown kind,
/// a reason over kMaxSessionReason or in pieces, or bytes past `total`.
SessionPiece parse_session_piece(std::span<const uint8_t> data);

/// Puts pieces back together, one message in progress per `stream` (a relay's subject).
class PieceAssembler {
 public:
  /// `max_streams`: messages in progress at once (a new stream beyond it drops the oldest).
  explicit PieceAssembler(size_t max_streams = 64) : max_streams_(max_streams) {}
  /// Feeds piece `p` of `stream`; returns the whole message when `p` completes one. `limit`:
  /// the largest total this message may have, checked on its first piece before allocating
  /// (0: refused). Throws Error naming what was wrong (over the limit, a piece that does not
  /// follow on); the message in progress on `stream` is then dropped.
  std::optional<std::vector<uint8_t>> add(const std::string& stream, const SessionPiece& p,
                                          uint32_t limit);
  uint64_t dropped() const { return dropped_; }  ///< messages abandoned for a piece out of order

 private:
  struct Partial {
    SessionPiece head;  // of the first piece (bytes empty)
    std::vector<uint8_t> bytes;
    uint64_t order = 0;
  };
  size_t max_streams_;
  uint64_t order_ = 0, dropped_ = 0;
  std::map<std::string, Partial> partial_;
};

/// Publishes `message` for `viewer` in pieces on `subject` (at most the connection's
/// max_payload each). The caller keeps pieces of two messages on one subject from interleaving.
void publish_session_message(NatsConnection& nats, const std::string& subject, PieceKind kind,
                             uint8_t type, uint64_t viewer, uint64_t coalesce_key,
                             std::span<const uint8_t> message);

struct SessionLinkStats {
  uint64_t messages_in = 0, messages_out = 0;  ///< whole session messages
  uint64_t viewers = 0;                        ///< remote viewers known now (bridge)
  uint64_t malformed = 0;     ///< pieces refused (a bad header, over a limit, out of order)
  uint64_t refused = 0;       ///< viewers dropped: a message the hub refused, or too many viewers
  uint64_t errors = 0;        ///< publishes that failed (NATS down past libnats' buffer)
  uint64_t rate_limited = 0;  ///< viewers' messages dropped over their limit (forwarder)
  std::string last_error;
};

/// The site's end: takes the relays' pieces (volcast.<site>.session.up.*) to the hub as
/// messages of remote viewers, and the hub's messages for them back to their relays. One
/// remote viewer per (relay, relay's viewer id); a relay's viewer that leaves, or is refused, or
/// is disconnected by the hub is forgotten. At most `max_viewers` remote viewers at once: a new
/// one beyond it pushes out the one silent longest (its session membership ends as if it left).
class SessionBridge final : public SessionOutlet {
 public:
  /// Subscribes. `hub` (the SessionHub: its SessionPort face) must outlive the bridge; call
  /// hub.attach_remote(&bridge) after, and attach_remote(nullptr) before it is destroyed.
  /// Throws Error if NATS refuses the subscription (permissions).
  SessionBridge(NatsConnection& nats, std::string site, SessionPort& hub,
                size_t max_viewers = 1024);
  ~SessionBridge() override;  ///< unsubscribes (waits for a callback in progress)
  SessionBridge(const SessionBridge&) = delete;
  SessionBridge& operator=(const SessionBridge&) = delete;

  bool send_session(uint64_t viewer, std::shared_ptr<const std::vector<uint8_t>> message,
                    uint64_t coalesce_key = 0) override;
  void disconnect(uint64_t viewer, const std::string& why) override;
  SessionLinkStats stats() const;

 private:
  struct Remote {
    std::string relay;
    uint64_t viewer = 0;
    std::chrono::steady_clock::time_point last_seen;
  };
  void on_piece(const std::string& subject, std::span<const uint8_t> data);
  // The hub's id of (relay, viewer), made if new (pushing out the longest silent if full).
  uint64_t id_of(const std::string& relay, uint64_t viewer, std::vector<uint64_t>& pushed_out);
  void drop(uint64_t id, const std::string& why);  // tells the relay and the hub
  void publish(const std::string& relay, PieceKind kind, uint64_t viewer, uint64_t key,
               std::span<const uint8_t> bytes);

  NatsConnection& nats_;
  std::string site_;
  SessionPort& hub_;
  size_t max_viewers_;
  mutable std::mutex mutex_;                                  // the maps and stats
  std::map<uint64_t, Remote> remotes_;                        // by hub id
  std::map<std::pair<std::string, uint64_t>, uint64_t> ids_;  // (relay, viewer) -> hub id
  uint64_t next_id_ = 1;
  SessionLinkStats stats_;
  std::mutex publish_mutex_;  // pieces of one message stay together
  PieceAssembler assembler_;  // the subscription's thread only
  std::unique_ptr<NatsConnection::Subscription> sub_;
};

/// The relay's end: the SessionPort of the relay's Server. Its viewers' session messages go up
/// to the site's hub, each within its type's rate limit per viewer (session/rate_limit.hpp, the
/// hub's limits: over it a message is dropped here, before NATS, and the viewer told once per
/// burst by a SessionError); the hub's messages for them come down and are queued to them
/// (Server::send_session) or end their connection.
class SessionForwarder final : public SessionPort {
 public:
  /// `relay`: this relay's subject token, unique among the site's relays (a random one is made
  /// when empty). Subscribes to its down subject. Throws Error if NATS refuses.
  SessionForwarder(NatsConnection& nats, std::string site, std::string relay = {});
  ~SessionForwarder() override;
  SessionForwarder(const SessionForwarder&) = delete;
  SessionForwarder& operator=(const SessionForwarder&) = delete;

  /// The relay's server (its ServerConfig::session is this); null detaches, before it goes.
  void attach(SessionOutlet* server);
  const std::string& relay() const { return relay_; }
  SessionLinkStats stats() const;

  uint32_t max_payload(uint8_t type) const override;
  void on_message(uint64_t viewer, uint8_t type, std::span<const uint8_t> payload) override;
  void on_viewer_left(uint64_t viewer, const std::string& why) override;

 private:
  void on_piece(std::span<const uint8_t> data);
  void publish(PieceKind kind, uint8_t type, uint64_t viewer, std::span<const uint8_t> bytes);

  NatsConnection& nats_;
  std::string site_, relay_, up_;
  mutable std::mutex mutex_;  // server_, stats_
  SessionOutlet* server_ = nullptr;
  SessionLinkStats stats_;
  std::mutex publish_mutex_;
  session::RateLimiter limiter_;
  PieceAssembler assembler_;  // the subscription's thread only
  std::unique_ptr<NatsConnection::Subscription> sub_;
};

}  // namespace volcast::cluster
