#pragma once
// Connection: a byte stream to one peer with deadlines, the seam between the protocol and its
// transports: plain TCP (here; loopback only outside tests), TLS 1.3 (tls.hpp) and WebSocket over
// TLS for browsers (src/net/websocket.hpp).
// A silent or stalled peer can never hold a thread forever: every blocking call has a deadline and
// shutdown() from any thread ends it. One thread at a time reads and writes a connection.
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
  /// Like write_all(parts), then writes `raw` right after them on the same stream, bypassing the
  /// transport's protection: bytes the caller has sealed itself (protocol.hpp, SealedFrameSet). On
  /// TLS the records of `parts` end exactly where `raw` begins, and both go out in one gather
  /// write; on plain TCP `raw` is just more bytes. Throws Error like write_all.
  virtual void write_with_raw(std::span<const std::span<const uint8_t>> parts,
                              std::span<const uint8_t> raw, int stall_ms) = 0;
  /// Reads exactly `data.size()` bytes that the peer wrote as write_with_raw's `raw`. On TLS,
  /// throws Error if decrypted or undecrypted TLS bytes are still buffered (a record that
  /// straddles the raw bytes: the peer broke the framing). Otherwise like read_exact.
  virtual void read_raw(std::span<uint8_t> data, int timeout_ms) = 0;
  /// True if the transport encrypts and authenticates what write_all writes (TLS).
  virtual bool encrypted() const = 0;
  /// True if write_with_raw's `raw` bytes reach the peer as a plain byte stream (TCP, TLS); false
  /// for a message transport (WebSocket), which the server never sends sealed frame sets.
  virtual bool carries_raw() const { return true; }

  struct Ready {
    bool readable = false;  ///< bytes (or the peer's close) can be read without blocking
    bool woken = false;     ///< `wake_fd` became readable
  };
  /// Waits until the connection is readable or `wake_fd` (an eventfd or pipe, -1 for none) is,
  /// at most `timeout_ms` (< 0: no limit). Does not consume the wake fd's counter.
  virtual Ready wait(int wake_fd, int timeout_ms) = 0;
  /// Reads whatever is available now, at most `data.size()` bytes, without blocking; 0 when
  /// nothing is. Throws Error like read_exact (e.g. "peer closed the connection").
  virtual size_t read_available(std::span<uint8_t> data) = 0;
  /// Advances the transport's own handshake (TLS) without blocking: 0 when it is complete, else the
  /// poll(2) events (POLLIN, POLLOUT) the socket must become ready for before the next call.
  /// Throws Error if the handshake failed. A transport without a handshake returns 0 at once.
  virtual int handshake_step() = 0;
  /// The socket, for poll(2) by a caller multiplexing many connections (it stays owned here).
  virtual int fd() const = 0;
  /// send_buffer_full(fd()).
  bool send_buffer_full() const;
  /// "address:port" of the peer, for logs.
  virtual std::string peer() const = 0;
  /// Ends the connection: calls blocked in other threads return by throwing Error. Thread-safe
  /// and idempotent.
  virtual void shutdown() = 0;
};

/// Whether socket `fd`'s send buffer is full now (poll(2) gives no POLLOUT): its peer or path
/// takes bytes slower than they are written. False for a socket that takes bytes, or fd < 0.
/// Thread-safe: a write may be blocked on the socket in another thread.
bool send_buffer_full(int fd);

/// Connects over TCP (TCP_NODELAY and keepalive on), trying each address HOST resolves to within
/// `timeout_ms` in all. Throws Error("cannot connect to HOST:PORT: reason").
std::unique_ptr<Connection> connect_tcp(const std::string& host, uint16_t port,
                                        int timeout_ms = 5000);
/// Wraps a connected socket (owned from here on) as a plain TCP connection.
std::unique_ptr<Connection> make_tcp_connection(int fd, std::string peer);
/// Configures a stream socket as every Volcast connection is: non-blocking, TCP_NODELAY, BBR
/// congestion control where the kernel has it, and TCP keepalive (a peer that vanishes without a
/// FIN is noticed within about 20 s even when nothing is being sent).
void configure_stream_socket(int fd);

/// An accepted socket not yet wrapped in a Connection.
struct AcceptedSocket {
  int fd = -1;          ///< owned by the caller
  std::string peer;     ///< "address:port"
  std::string address;  ///< the address alone (for per-address limits)
};

/// Resolves a bind address: an IP address, or a host name such as "localhost" (its first IPv4
/// address, else its first IPv6 one). Throws Error("cannot listen on HOST: reason").
std::string resolve_bind_address(const std::string& host);
/// True for 127.0.0.0/8, ::1 and names resolving only to them.
bool is_loopback_address(const std::string& host);

/// Listens on TCP and hands out accepted connections.
class TcpListener {
 public:
  /// Binds and listens on `bind_address` (see resolve_bind_address). Throws Error("cannot listen on
  /// ADDRESS:PORT: reason").
  TcpListener(const std::string& bind_address, uint16_t port);
  ~TcpListener();
  TcpListener(const TcpListener&) = delete;
  TcpListener& operator=(const TcpListener&) = delete;
  uint16_t port() const;
  /// Blocks for the next connection (TCP_NODELAY on, BBR congestion control where the kernel has
  /// it); nullptr once close() was called. Transient failures are retried.
  std::unique_ptr<Connection> accept();
  /// The next pending connection without blocking (nothing configured yet), or fd -1 when none
  /// is waiting. For a caller polling fd() itself.
  AcceptedSocket accept_nonblocking();
  /// The listening socket, for poll(2).
  int fd() const { return fd_; }
  /// Unblocks accept() and stops listening. Thread-safe, idempotent.
  void close();

 private:
  int fd_ = -1;
  uint16_t port_ = 0;
  std::atomic<bool> closed_{false};
};

}  // namespace volcast
