#pragma once
// Internal to src/net (the Server's): the server side of HTTP/1.1 and WebSocket (RFC 6455) for
// browser viewers, as a byte-in / byte-out engine over WebSocket++ (Debian's libwebsocketpp-dev,
// its iostream transport: no sockets of its own). websocket.cpp runs it on top of a TLS Connection.
//
// This header is C++17 (no std::span): ws_engine.cpp is compiled as C++17 because WebSocket++
// 0.8.2 does not compile as C++20 with GCC (template-ids on constructors, P1787).
//
// An engine serves one connection: a GET for a file in its WebAssets is answered with the file
// (200), a HEAD with GET's head alone, an unknown path with 404, another method with 405 (Allow:
// GET, HEAD), a request that announces a body (Content-Length > 0, or any Transfer-Encoding) with
// 413 at its head, the body unread; then it is done (no keep-alive). A GET of /stream with a
// WebSocket upgrade opens a WebSocket whose binary messages it hands on.
#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <string>

namespace volcast::detail {

/// A file the server serves to browsers.
struct WebFile {
  std::string content_type;  ///< e.g. "text/javascript"
  std::string bytes;
};
/// URL path ("/index.html") -> file; "/" serves "/index.html".
using WebAssets = std::map<std::string, WebFile>;

class WsEngine {
 public:
  enum class State {
    kRequest,    ///< reading the HTTP request
    kOpen,       ///< the WebSocket is open
    kResponded,  ///< a plain HTTP request was answered: write output(), then close
    kClosed,     ///< the peer closed the WebSocket (or it failed: error())
  };
  /// `assets` may be empty (then only /stream exists). `max_message_bytes` bounds one incoming
  /// message (a longer one closes the WebSocket with 1009, "message too big").
  WsEngine(std::shared_ptr<const WebAssets> assets, size_t max_message_bytes);
  ~WsEngine();
  WsEngine(const WsEngine&) = delete;
  WsEngine& operator=(const WsEngine&) = delete;

  /// Feeds bytes received from the peer. Complete binary messages' payloads are appended to
  /// inbox(); a text message closes the WebSocket (1003). Bytes after the engine is done are
  /// dropped.
  void feed(const uint8_t* data, size_t n);
  /// Bytes to write to the peer, in order (HTTP responses, control frames); the caller writes
  /// and clears it.
  std::string& output();
  /// Payload bytes of the binary messages received, in order; the caller consumes from the front.
  std::string& inbox();
  State state() const;
  /// Why the WebSocket closed or failed, for logs.
  std::string error() const;
  /// The HTTP request's path, once read ("" before).
  std::string path() const;
  /// Changes the incoming message bound (e.g. raised once the peer is authenticated).
  void set_max_message_bytes(size_t bytes);
  /// Whether pings are answered with pongs (RFC 6455 5.5.2). Off at first: until its peer is
  /// authenticated nothing is buffered for it, and its pings are read and dropped.
  void set_answer_pings(bool answer);
  /// The header of one unmasked, final binary frame of `payload_bytes` (RFC 6455 5.2, server to
  /// client), made by WebSocket++: the caller writes it, then the payload.
  static std::string binary_frame_header(uint64_t payload_bytes);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace volcast::detail
