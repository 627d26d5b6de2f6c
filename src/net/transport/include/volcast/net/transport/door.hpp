#pragma once
// The server's door (internal to src/net: the Server's): one thread accepts connections and runs
// every pending handshake -- TLS, then the Hello with its join token -- without a thread per peer,
// and hands only authenticated viewers on. Unauthenticated peers never reach the tiers, cost no
// encoding, and are never logged with their own bytes.
//
// Policy: a handshake must finish within `handshake_timeout_ms`; at most `max_pending` handshakes
// run at once (the oldest is dropped for a newcomer) and `max_pending_per_address` per peer
// address (more are closed at once). Tokens are compared in constant time. A right token is
// always accepted; an address that sent `free_wrong_tokens` wrong tokens is backed off: its wrong
// tokens are refused with "try again in" for 1 s, doubling with each further one up to 60 s
// (forgotten after 10 quiet minutes). A connection that speaks HTTP may send kPendingWebBytes
// before its Hello. Failures are logged at most once per 10 s, with a count.
#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "volcast/net/protocol/join.hpp"
#include "volcast/net/protocol/protocol.hpp"
#include "volcast/net/transport/connection.hpp"
#include "volcast/net/transport/tls.hpp"
#include "volcast/net/transport/ws_engine.hpp"

namespace volcast::detail {

/// An authenticated browser's incoming WebSocket messages are bounded by this (bytes): a session
/// avatar frame (session/messages.hpp, 8 MiB) with its headers. Before its Hello, a Hello's size.
inline constexpr size_t kMaxWebMessageBytes = (8u << 20) + (64u << 10);
/// The byte budget of a connection that speaks HTTP before its Hello: what the door reads from it
/// (after TLS) until its Hello is complete -- its request's head (WebSocket++ takes at most 16000
/// bytes), the WebSocket frames and the Hello (protocol::kMaxHelloBytes), with room to spare.
/// Nothing is written to it meanwhile but the answer to its request (no pong: websocket.hpp).
/// Over the budget (a flood of pings, say) it is closed, the log naming the limit.
inline constexpr size_t kPendingWebBytes = 64u << 10;

struct DoorConfig {
  std::shared_ptr<const TlsContext> tls;  ///< null: plain TCP (loopback only, checked by Server)
  /// Page assets for browsers (websocket.hpp): with them, a peer that speaks HTTP after TLS gets
  /// its file, or a WebSocket (on /stream) that carries the protocol. Null: Volcast peers only.
  std::shared_ptr<const WebAssets> web;
  JoinToken token{};
  int handshake_timeout_ms = 5000;
  int max_pending = 64;
  int max_pending_per_address = 8;
  /// Wrong tokens an address may send before it is backed off (the Server's kFreeWrongTokens).
  int free_wrong_tokens = 3;
};

/// Counts of what came to the door, updated by its thread, read from any.
struct DoorCounters {
  std::atomic<uint64_t> admitted{0};     ///< authenticated (then admitted or rejected by policy)
  std::atomic<uint64_t> wrong_token{0};  ///< refused: wrong join token
  std::atomic<uint64_t> backed_off{0};   ///< wrong tokens during their address's back-off
  std::atomic<uint64_t> failed{0};       ///< TLS or protocol errors, handshake timeouts
  std::atomic<uint64_t> over_limit{0};   ///< closed at once: too many pending handshakes
  std::atomic<uint64_t> web_files{0};    ///< page assets answered (browsers)
  std::atomic<uint64_t> web_viewers{0};  ///< authenticated over WebSocket (also in `admitted`)
};

/// An authenticated viewer: its connection (handshake done) and its Hello.
struct Admitted {
  std::unique_ptr<Connection> connection;
  protocol::Hello hello;
  std::string address;  ///< the peer's IP address (no port), for per-address policy
};

/// Runs the door on `listener` until `stopping` becomes true; calls `admit` (on this thread) for
/// each authenticated viewer. `admit` may throw Error: the viewer is then sent a Reject with its
/// message and closed.
void run_door(TcpListener& listener, const DoorConfig& config, const std::atomic<bool>& stopping,
              const std::function<void(Admitted&)>& admit, DoorCounters& counters);

/// Writes a Reject with `reason` (already safe to show) without waiting more than 200 ms.
void send_reject(Connection& c, const std::string& reason);

}  // namespace volcast::detail
