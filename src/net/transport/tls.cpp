#include "volcast/net/transport/tls.hpp"

#include <fcntl.h>
#include <openssl/err.h>
#include <openssl/evp.h>
#include <openssl/pem.h>
#include <openssl/rand.h>
#include <openssl/ssl.h>
#include <openssl/x509.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <asio.hpp>
#include <asio/ssl.hpp>
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <vector>

#include "socket_io.hpp"
#include "volcast/core/error.hpp"

#include "tls_internal.hpp"

namespace volcast {
namespace {

using Clock = std::chrono::steady_clock;
using detail::fingerprint_of;
using detail::openssl_error;
using detail::X509Ptr;

int remaining_ms(Clock::time_point deadline) {
  const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
  return static_cast<int>(std::max<int64_t>(0, left.count()));
}

// The socket under a TLS connection, as an OpenSSL BIO:
// - it writes with MSG_NOSIGNAL (OpenSSL's own socket BIO uses write(2), which raises SIGPIPE when
//   the peer has gone -- and would kill a server over one viewer that left mid-handshake);
// - it gathers the records of one write_all (a 16 KiB TLS record each) and sends them with as few
//   send(2) calls as the socket takes, at flush or when kGatherBytes are waiting, instead of one
//   call per record: for a frame set of a few hundred KiB that is 1 call instead of ~16.
struct SocketBio {
  int fd = -1;
  std::vector<uint8_t> out;  // records not yet sent: out[sent, size)
  size_t sent = 0;
  static constexpr size_t kGatherBytes = 512 << 10;

  size_t pending() const { return out.size() - sent; }
  // Sends what the socket takes now. False on a socket error (errno set).
  bool drain() {
    while (sent < out.size()) {
      const ssize_t w = ::send(fd, out.data() + sent, out.size() - sent, MSG_NOSIGNAL);
      if (w > 0) {
        sent += static_cast<size_t>(w);
        continue;
      }
      if (w < 0 && errno == EINTR) continue;
      if (w < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) break;
      return false;
    }
    if (sent == out.size()) {
      out.clear();  // keeps its capacity: no allocation per frame set
      sent = 0;
    }
    return true;
  }
};

SocketBio& socket_of(BIO* b) {
  return *static_cast<SocketBio*>(BIO_get_data(b));
}

int bio_write(BIO* b, const char* data, int n) {
  BIO_clear_retry_flags(b);
  SocketBio& s = socket_of(b);
  if (s.pending() + static_cast<size_t>(n) > SocketBio::kGatherBytes) {
    if (!s.drain()) return -1;
    if (s.pending() > 0 && s.pending() + static_cast<size_t>(n) > SocketBio::kGatherBytes) {
      BIO_set_retry_write(b);
      return -1;
    }
  }
  if (s.sent > 0 && s.sent == s.out.size()) s.drain();
  const size_t at = s.out.size();
  s.out.resize(at + static_cast<size_t>(n));  // capacity kept: no allocation once warm
  std::memcpy(s.out.data() + at, data, static_cast<size_t>(n));
  return n;
}

int bio_read(BIO* b, char* data, int n) {
  BIO_clear_retry_flags(b);
  const ssize_t r = ::recv(socket_of(b).fd, data, static_cast<size_t>(n), 0);
  if (r < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)) BIO_set_retry_read(b);
  return static_cast<int>(r);
}

long bio_ctrl(BIO* b, int cmd, long, void*) {
  SocketBio& s = socket_of(b);
  if (cmd == BIO_CTRL_WPENDING) return static_cast<long>(s.pending());
  if (cmd != BIO_CTRL_FLUSH) return 0;
  BIO_clear_retry_flags(b);
  if (!s.drain()) return -1;
  if (s.pending() == 0) return 1;
  BIO_set_retry_write(b);
  return 0;
}

int bio_create(BIO* b) {
  BIO_set_data(b, new SocketBio);
  BIO_set_init(b, 1);
  return 1;
}

int bio_destroy(BIO* b) {
  delete static_cast<SocketBio*>(BIO_get_data(b));
  BIO_set_data(b, nullptr);
  return 1;
}

const BIO_METHOD* socket_method() {
  static BIO_METHOD* method = [] {
    BIO_METHOD* m = BIO_meth_new(BIO_get_new_index() | BIO_TYPE_SOURCE_SINK, "volcast socket");
    BIO_meth_set_write(m, bio_write);
    BIO_meth_set_read(m, bio_read);
    BIO_meth_set_ctrl(m, bio_ctrl);
    BIO_meth_set_create(m, bio_create);
    BIO_meth_set_destroy(m, bio_destroy);
    return m;
  }();
  return method;
}

}  // namespace

namespace {

class TlsConnection final : public Connection {
 public:
  TlsConnection(int fd, std::string peer, std::shared_ptr<const TlsContext> context, bool server)
      : fd_(fd), peer_(std::move(peer)), context_(std::move(context)) {
    configure_stream_socket(fd_);
    ssl_ = SSL_new(context_->impl().context.native_handle());
    BIO* bio = ssl_ ? BIO_new(socket_method()) : nullptr;
    if (!bio) {
      if (ssl_) SSL_free(ssl_);
      ::close(fd_);
      throw Error("cannot start TLS: " + openssl_error());
    }
    socket_of(bio).fd = fd_;
    SSL_set_bio(ssl_, bio, bio);  // ssl_ owns it
    // Records are read one at a time, never ahead: raw bytes after a record stay in the socket.
    SSL_set_read_ahead(ssl_, 0);
    server_ = server;
    if (server)
      SSL_set_accept_state(ssl_);
    else
      SSL_set_connect_state(ssl_);
  }
  ~TlsConnection() override {
    if (handshaken_ && !failed_ && !shut_) {
      ERR_clear_error();
      SSL_shutdown(ssl_);  // close_notify, best effort (non-blocking)
    }
    SSL_free(ssl_);
    ERR_clear_error();
    ::close(fd_);
  }

  int handshake_step() override {
    if (handshaken_) return 0;
    check_open();
    ERR_clear_error();
    const int rc = SSL_do_handshake(ssl_);
    if (rc == 1) {
      handshaken_ = true;
      return 0;
    }
    const int err = SSL_get_error(ssl_, rc);
    if (err == SSL_ERROR_WANT_READ) return POLLIN;
    if (err == SSL_ERROR_WANT_WRITE) return POLLOUT;
    failed_ = true;
    if (err == SSL_ERROR_SYSCALL || err == SSL_ERROR_ZERO_RETURN) {
      ERR_clear_error();
      throw TlsHandshakeDropped("TLS handshake failed: the peer closed the connection");
    }
    const std::string why = openssl_error();
    if (server_ && BIO_number_written(SSL_get_wbio(ssl_)) == 0) {
      // Not TLS at all (OpenSSL answers nothing then): one fatal protocol_version alert record
      // (RFC 8446 sec. 6), so a plain-TCP client learns this is TLS -- and nothing else.
      static const uint8_t kAlert[] = {0x15, 0x03, 0x03, 0x00, 0x02, 0x02, 0x46};
      [[maybe_unused]] const ssize_t n = ::send(fd_, kAlert, sizeof kAlert, MSG_NOSIGNAL);
    }
    throw Error("TLS handshake failed: " + why);
  }

  void read_exact(std::span<uint8_t> data, int timeout_ms) override {
    const auto deadline = Clock::now() + std::chrono::milliseconds(std::max(timeout_ms, 0));
    size_t done = 0;
    while (done < data.size()) {
      const int want = read_some(data.subspan(done), done);
      if (want == 0) continue;
      if (timeout_ms >= 0 && Clock::now() >= deadline)
        throw Error("timed out waiting for the peer");
      poll_fd(static_cast<short>(want), timeout_ms < 0 ? -1 : remaining_ms(deadline));
    }
  }

  size_t read_available(std::span<uint8_t> data) override {
    size_t done = 0;
    try {
      while (done < data.size() && read_some(data.subspan(done), done) == 0) {
      }
    } catch (const Error&) {
      if (done == 0) throw;  // else the bytes before the close now, the close at the next call
    }
    return done;
  }

  void write_all(std::span<const std::span<const uint8_t>> parts, int stall_ms) override {
    write_with_raw(parts, {}, stall_ms);
  }

  void write_with_raw(std::span<const std::span<const uint8_t>> parts, std::span<const uint8_t> raw,
                      int stall_ms) override {
    auto last_progress = write_records(parts, stall_ms);
    if (raw.empty()) {
      flush(last_progress, stall_ms);
      return;
    }
    // The records gathered in the BIO, then the raw bytes: one gather write, and the records end
    // exactly where the raw bytes begin (OpenSSL writes nothing between SSL_write calls).
    SocketBio& s = socket_of(SSL_get_wbio(ssl_));
    iovec iov[2];
    size_t count = 0;
    if (s.pending() > 0) iov[count++] = {s.out.data() + s.sent, s.pending()};
    iov[count++] = {const_cast<uint8_t*>(raw.data()), raw.size()};
    try {
      detail::send_all(fd_, iov, count, stall_ms, shut_);
    } catch (const Error&) {
      failed_ = true;  // the stream is cut mid-message: nothing more may be written
      throw;
    }
    s.out.clear();  // keeps its capacity
    s.sent = 0;
  }

  void read_raw(std::span<uint8_t> data, int timeout_ms) override {
    check_open();
    if (SSL_has_pending(ssl_))
      throw Error(
          "TLS bytes are buffered where raw bytes should begin (a record straddles them: the peer "
          "broke the framing)");
    detail::recv_exact(fd_, data, timeout_ms, shut_);
  }

  bool encrypted() const override { return true; }

  Ready wait(int wake_fd, int timeout_ms) override {
    check_open();
    Ready r;
    if (SSL_has_pending(ssl_)) {  // decrypted (or raw) bytes already buffered inside OpenSSL
      r.readable = true;
      return r;
    }
    pollfd p[2] = {{fd_, POLLIN, 0}, {wake_fd, POLLIN, 0}};
    const int n = ::poll(p, wake_fd >= 0 ? 2 : 1, timeout_ms);
    if (n > 0) {
      r.readable = p[0].revents != 0;
      r.woken = wake_fd >= 0 && p[1].revents != 0;
    }
    return r;
  }

  int fd() const override { return fd_; }
  std::string peer() const override { return peer_; }

  void shutdown() override {
    if (shut_.exchange(true)) return;
    ::shutdown(fd_, SHUT_RDWR);  // wakes poll() in other threads; no SSL call from this thread
  }

  std::string peer_fingerprint() const {
    X509* cert = SSL_get1_peer_certificate(ssl_);
    if (!cert) return {};
    X509Ptr owned(cert);
    return fingerprint_of(cert);
  }

 private:
  // SSL_write of every part: the records gather in the BIO (sent when it holds kGatherBytes).
  // Returns when the last write made progress.
  Clock::time_point write_records(std::span<const std::span<const uint8_t>> parts, int stall_ms) {
    auto last_progress = Clock::now();
    for (const auto& part : parts) {
      size_t done = 0;
      while (done < part.size()) {
        check_open();
        ERR_clear_error();
        size_t n = 0;
        const int rc = SSL_write_ex(ssl_, part.data() + done, part.size() - done, &n);
        if (rc == 1) {
          done += n;
          last_progress = Clock::now();
          continue;
        }
        const int err = SSL_get_error(ssl_, rc);
        short want = 0;
        if (err == SSL_ERROR_WANT_WRITE)
          want = POLLOUT;
        else if (err == SSL_ERROR_WANT_READ)
          want = POLLIN;
        else
          fail(shut_ ? "connection shut down" : "write failed", err);
        const auto deadline = last_progress + std::chrono::milliseconds(stall_ms);
        if (Clock::now() >= deadline)
          throw Error("peer stalled: accepted no data for " + std::to_string(stall_ms) + " ms");
        poll_fd(want, remaining_ms(deadline));
      }
    }
    return last_progress;
  }

  // Sends the records gathered in the BIO (SocketBio).
  void flush(Clock::time_point last_progress, int stall_ms) {
    BIO* wbio = SSL_get_wbio(ssl_);
    size_t left = BIO_wpending(wbio);
    while (BIO_flush(wbio) <= 0) {
      check_open();
      if (!BIO_should_retry(wbio))
        fail(shut_ ? "connection shut down" : "write failed", SSL_ERROR_SYSCALL);
      if (const size_t now_left = BIO_wpending(wbio); now_left < left) {
        left = now_left;
        last_progress = Clock::now();
      }
      const auto deadline = last_progress + std::chrono::milliseconds(stall_ms);
      if (Clock::now() >= deadline)
        throw Error("peer stalled: accepted no data for " + std::to_string(stall_ms) + " ms");
      poll_fd(POLLOUT, remaining_ms(deadline));
    }
  }

  // One SSL_read into `data`: adds what it read to `done` and returns 0, or returns the poll(2)
  // events to wait for before trying again. Throws on close or error.
  int read_some(std::span<uint8_t> data, size_t& done) {
    check_open();
    if (!handshaken_) {
      const int want = handshake_step();
      if (want != 0) return want;
    }
    ERR_clear_error();
    size_t n = 0;
    const int rc = SSL_read_ex(ssl_, data.data(), data.size(), &n);
    if (rc == 1) {
      done += n;
      return 0;
    }
    const int err = SSL_get_error(ssl_, rc);
    if (err == SSL_ERROR_WANT_READ) return POLLIN;
    if (err == SSL_ERROR_WANT_WRITE) return POLLOUT;
    if (err == SSL_ERROR_ZERO_RETURN)
      throw Error(shut_ ? "connection shut down" : "peer closed the connection");
    fail("read failed", err);
  }

  [[noreturn]] void fail(const std::string& what, int err) {
    failed_ = true;
    if (shut_) throw Error("connection shut down");
    if (err == SSL_ERROR_SYSCALL) {
      ERR_clear_error();
      if (errno == 0 || errno == EPIPE || errno == ECONNRESET)
        throw Error("peer closed the connection");
      throw Error(what + ": " + std::strerror(errno));
    }
    throw Error(what + ": TLS error: " + openssl_error());
  }
  void check_open() const {
    if (shut_) throw Error("connection shut down");
  }
  void poll_fd(short events, int timeout_ms) const {
    pollfd p{fd_, events, 0};
    ::poll(&p, 1, timeout_ms < 0 ? 100 : std::min(timeout_ms, 100));
  }

  int fd_;
  std::string peer_;
  std::shared_ptr<const TlsContext> context_;
  SSL* ssl_ = nullptr;
  bool server_ = false;
  bool handshaken_ = false;
  bool failed_ = false;
  std::atomic<bool> shut_{false};
};

}  // namespace

std::unique_ptr<Connection> accept_tls(int fd, std::string peer,
                                       std::shared_ptr<const TlsContext> context) {
  return std::make_unique<TlsConnection>(fd, std::move(peer), std::move(context), true);
}

TlsClientConnection connect_tls(const std::string& host, uint16_t port,
                                std::shared_ptr<const TlsContext> context, int timeout_ms) {
  const auto deadline = Clock::now() + std::chrono::milliseconds(std::max(timeout_ms, 1));
  std::unique_ptr<Connection> tcp = connect_tcp(host, port, timeout_ms);
  const std::string peer = tcp->peer();
  const int fd = ::dup(tcp->fd());  // the TLS connection takes its own descriptor
  tcp.reset();
  if (fd < 0) throw Error("cannot connect to " + peer + ": " + std::strerror(errno));
  auto tls = std::make_unique<TlsConnection>(fd, peer, std::move(context), false);
  const std::string where = host + ":" + std::to_string(port);
  const auto explained = [&](const Error& e) {
    return "cannot connect to " + where + ": " + e.what() +
           " (the server may be busy with other handshakes -- try again -- or speak plain TCP: "
           "a server started with --insecure needs view --insecure)";
  };
  try {
    while (const int want = tls->handshake_step()) {
      if (Clock::now() >= deadline) throw TlsHandshakeDropped("TLS handshake timed out");
      pollfd p{tls->fd(), static_cast<short>(want), 0};
      ::poll(&p, 1, std::min(remaining_ms(deadline), 100));
    }
  } catch (const TlsHandshakeDropped& e) {
    throw TlsHandshakeDropped(explained(e));
  } catch (const Error& e) {
    throw Error(explained(e));
  }
  TlsClientConnection out;
  out.server_fingerprint = tls->peer_fingerprint();
  out.connection = std::move(tls);
  return out;
}

}  // namespace volcast