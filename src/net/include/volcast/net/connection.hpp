#pragma once
// Connection: a byte stream to one peer with deadlines, the seam between the protocol and its
// transports. TCP today; TLS and WebSocket implement the same interface next. A silent or stalled
// peer can never hold a thread forever: every blocking call has a deadline and shutdown() from any
// thread ends it.
#include <atomic>
#include <cstdint>
#include <memory>
#include <span>
#include <string>

namespace volcast {

class Connection {
 public:
  virtual ~Connection() = default;

  /// Reads exactly `data.size()` bytes. `timeout_ms` < 0 waits without limit. Throws Error
  /// ("timed out waiting for the peer", "peer closed the connection", "connection shut down", or
  /// the system's reason).
  virtual void read_exact(std::span<uint8_t> data, int timeout_ms) = 0;
  /// Writes every byte of `parts` in order, as one gather write where it can (no copy into one
  /// buffer). Throws Error if the peer accepts nothing for `stall_ms`, the connection breaks, or it
  /// is shut down.
  virtual void write_all(std::span<const std::span<const uint8_t>> parts, int stall_ms) = 0;
  void write_all(std::span<const uint8_t> bytes, int stall_ms) {
    const std::span<const uint8_t> parts[1] = {bytes};
    write_all(parts, stall_ms);
  }

  struct Ready {
    bool readable = false;  ///< bytes (or the peer's close) can be read without blocking
    bool woken = false;     ///< `wake_fd` became readable
  };
  /// Waits until the connection is readable or `wake_fd` (an eventfd or pipe, -1 for none) is,
  /// at most `timeout_ms` (< 0: no limit). Does not consume the wake fd's counter.
  virtual Ready wait(int wake_fd, int timeout_ms) = 0;
  /// "address:port" of the peer, for logs.
  virtual std::string peer() const = 0;
  /// Ends the connection: calls blocked in other threads return by throwing Error. Thread-safe
  /// and idempotent.
  virtual void shutdown() = 0;
};

/// Connects over TCP (TCP_NODELAY on). Throws Error("cannot connect to HOST:PORT: reason").
std::unique_ptr<Connection> connect_tcp(const std::string& host, uint16_t port);

/// Listens on TCP and hands out accepted connections.
class TcpListener {
 public:
  /// Binds and listens. Throws Error("cannot listen on ADDRESS:PORT: reason").
  TcpListener(const std::string& bind_address, uint16_t port);
  ~TcpListener();
  TcpListener(const TcpListener&) = delete;
  TcpListener& operator=(const TcpListener&) = delete;
  uint16_t port() const;
  /// Blocks for the next connection (TCP_NODELAY on, BBR congestion control where the kernel has
  /// it); nullptr once close() was called. Transient failures are retried.
  std::unique_ptr<Connection> accept();
  /// Unblocks accept() and stops listening. Thread-safe, idempotent.
  void close();

 private:
  int fd_ = -1;
  uint16_t port_ = 0;
  std::atomic<bool> closed_{false};
};

}  // namespace volcast
