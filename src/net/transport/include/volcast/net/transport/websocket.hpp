#pragma once
// Internal to src/net (the Server's): browser viewers. A TLS connection that spoke HTTP instead of
// the Volcast Hello becomes a WebSocketConnection: a GET of a page asset is answered and closed; a
// WebSocket upgrade on /stream opens a WebSocket that carries the Volcast protocol unchanged
// (protocol.hpp), each write_all one binary message, read as a byte stream whatever the message
// boundaries. No raw bytes (carries_raw() is false): the server sends it FrameSet 1.1, never the
// sealed 1.2.
#include <filesystem>
#include <memory>
#include <span>
#include <string>

#include "volcast/net/transport/connection.hpp"
#include "volcast/net/transport/ws_engine.hpp"

namespace volcast::detail {

/// The page assets in `dir` (every regular file directly in it and in its subfolders, each at
/// most 16 MiB, 64 MiB in all), keyed by URL path, with a content type from the extension.
/// Throws Error naming the folder when it does not exist or holds no index.html.
WebAssets load_web_assets(const std::filesystem::path& dir);

class WebSocketConnection final : public Connection {
 public:
  /// Serves HTTP on `inner` (handshake done), whose first bytes `already_read` the door has read.
  /// Until authenticated(): incoming messages are bounded by `max_message_bytes`, pings are not
  /// answered, and at most `read_budget` bytes (already_read included) are read from `inner`
  /// -- reading more is refused: read_available and handshake_step throw Error naming the limit.
  WebSocketConnection(std::unique_ptr<Connection> inner, std::span<const uint8_t> already_read,
                      std::shared_ptr<const WebAssets> assets, size_t max_message_bytes,
                      size_t read_budget);
  ~WebSocketConnection() override;

  /// What the HTTP exchange came to: the WebSocket is open, a file was answered (the door hands
  /// the connection to a responder: take_response), or the peer is still sending its request.
  enum class Http { kReading, kOpen, kAnswered };
  Http http() const;
  /// The answered request's path and the bytes of the answer, and the connection to write them on.
  std::string path() const;
  std::string take_response();
  std::unique_ptr<Connection> release_inner();
  /// The peer is authenticated: its messages may be up to `max_message_bytes`, its pings are
  /// answered, and the read budget is lifted.
  void authenticated(size_t max_message_bytes);

  void read_exact(std::span<uint8_t> data, int timeout_ms) override;
  void write_all(std::span<const std::span<const uint8_t>> parts, int stall_ms) override;
  using Connection::write_all;
  /// Throws Error: nothing travels outside WebSocket messages.
  void write_with_raw(std::span<const std::span<const uint8_t>> parts, std::span<const uint8_t> raw,
                      int stall_ms) override;
  void read_raw(std::span<uint8_t> data, int timeout_ms) override;
  bool encrypted() const override;
  bool carries_raw() const override { return false; }
  Ready wait(int wake_fd, int timeout_ms) override;
  /// Reads at most kPumpBytes from the peer per call, and writes the answers to its control
  /// frames (pongs, a close) before returning: what waits unsent for a peer stays that small.
  size_t read_available(std::span<uint8_t> data) override;
  /// Reads and answers the HTTP request without blocking: 0 once the WebSocket is open or the
  /// request is answered (http() says which), else POLLIN. Throws Error for a request that
  /// failed (the engine's reason) or went over the read budget.
  int handshake_step() override;
  int fd() const override { return inner_->fd(); }
  std::string peer() const override { return inner_->peer(); }
  void shutdown() override { inner_->shutdown(); }

 private:
  // Reads what the inner connection has now into the engine; flushes the engine's output.
  void pump();
  void flush(int stall_ms);
  size_t take(std::span<uint8_t> data);

  static constexpr size_t kPumpBytes = 64u << 10;

  std::unique_ptr<Connection> inner_;
  WsEngine engine_;
  size_t inbox_offset_ = 0;  // consumed bytes at the front of engine_.inbox()
  size_t read_ = 0;          // bytes read from inner_ (and already_read)
  size_t read_budget_;       // SIZE_MAX once authenticated
};

}  // namespace volcast::detail
