#pragma once
// What the session service (src/session's SessionHub) and a server need from each other, without
// the server: the Server carries session-channel bytes (protocol.hpp channel 2) to a SessionPort,
// and the service answers through a SessionOutlet (the Server, or a relay's NATS bridge).
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace volcast {

/// A coalesce key with this bit set marks a stream of messages that must not replace each other
/// (voice: every packet plays). A receiver that does not keep up loses its oldest first, and
/// nobody else waits: with kMaxQueuedPerStream of one key queued while its connection's send
/// buffer is full (the receiver or its path is slow), one more drops the oldest of them. A
/// backlog of the sending thread's own (a loaded machine did not run it: the socket takes bytes)
/// is no reason to lose speech: it is kept up to kMaxHeldPerStream, 1 s of voice.
inline constexpr uint64_t kQueuedStreamKey = uint64_t{1} << 62;
inline constexpr size_t kMaxQueuedPerStream = 8;
inline constexpr size_t kMaxHeldPerStream = 50;

/// Queues `message` under `key` in `outbox` (pairs of key and message, in send order): key 0
/// appends; a key with kQueuedStreamKey appends after dropping the oldest of its key when
/// kMaxQueuedPerStream are queued and `receiver_behind()` says so, or kMaxHeldPerStream are; any
/// other key replaces a queued message with the same key, or appends. `receiver_behind` (a
/// callable returning bool, e.g. Connection::send_buffer_full) is called only at that point.
/// Returns the number of messages dropped (0 or 1). For Server and Client outboxes.
template <typename Outbox, typename Message, typename Behind>
size_t queue_session_message(Outbox& outbox, uint64_t key, Message message,
                             Behind&& receiver_behind) {
  size_t dropped = 0;
  if (key & kQueuedStreamKey) {
    size_t queued = 0;
    for (const auto& m : outbox) queued += m.first == key;
    if (queued >= kMaxHeldPerStream || (queued >= kMaxQueuedPerStream && receiver_behind()))
      for (auto it = outbox.begin(); it != outbox.end(); ++it)
        if (it->first == key) {
          outbox.erase(it);
          dropped = 1;
          break;
        }
  } else if (key != 0) {
    for (auto& m : outbox)
      if (m.first == key) {
        m.second = std::move(message);
        return 0;
      }
  }
  outbox.emplace_back(key, std::move(message));
  return dropped;
}

/// The service behind the session channel (protocol.hpp channel 2; src/session's SessionHub). The
/// server only carries its bytes: it calls these on the viewer's own thread, never while holding
/// its own locks, and a viewer's session messages in the order they arrived.
class SessionPort {
 public:
  virtual ~SessionPort() = default;
  /// The largest payload (bytes) a viewer may send in a session message of `type`; 0 for a type
  /// that does not exist (the viewer is then dropped). Checked before the payload is read.
  virtual uint32_t max_payload(uint8_t type) const = 0;
  /// A session message from viewer `viewer` (ViewerReport::id). Throwing Error drops that viewer
  /// (a malformed or hostile message), with what() as the reason; nobody else is touched.
  virtual void on_message(uint64_t viewer, uint8_t type, std::span<const uint8_t> payload) = 0;
  /// Viewer `viewer` has gone (closed, dropped, stalled, server stopping); `why` says how.
  virtual void on_viewer_left(uint64_t viewer, const std::string& why) = 0;
};

/// Where the session service's messages for viewers go: the Server for its own viewers, a NATS
/// session bridge (cluster/session_link.hpp) for viewers of relays.
class SessionOutlet {
 public:
  virtual ~SessionOutlet() = default;
  /// Queues a whole session-channel message (protocol.hpp channel 2, header included) for
  /// `viewer`; `coalesce_key` != 0 replaces a queued message with the same key, or with
  /// kQueuedStreamKey set queues up to kMaxQueuedPerStream of it. Never blocks on
  /// the network. Returns false if there is no such viewer (gone). Thread-safe.
  virtual bool send_session(uint64_t viewer, std::shared_ptr<const std::vector<uint8_t>> message,
                            uint64_t coalesce_key = 0) = 0;
  /// Ends viewer `viewer`'s connection, saying `why`; on_viewer_left follows. Thread-safe.
  virtual void disconnect(uint64_t viewer, const std::string& why) = 0;
};

}  // namespace volcast
