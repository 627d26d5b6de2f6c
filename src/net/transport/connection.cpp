#include "volcast/net/transport/connection.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <asio.hpp>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <vector>

#include "socket_io.hpp"
#include "volcast/core/error.hpp"

namespace volcast {

bool send_buffer_full(int fd) {
  pollfd p{fd, POLLOUT, 0};
  return fd >= 0 && ::poll(&p, 1, 0) == 0;
}

bool Connection::send_buffer_full() const {
  return volcast::send_buffer_full(fd());
}
namespace {

using Clock = std::chrono::steady_clock;

std::string errno_text() {
  return std::strerror(errno);
}

std::string endpoint_text(const sockaddr_storage& a) {
  char host[INET6_ADDRSTRLEN] = "?";
  uint16_t port = 0;
  if (a.ss_family == AF_INET) {
    const auto* v4 = reinterpret_cast<const sockaddr_in*>(&a);
    inet_ntop(AF_INET, &v4->sin_addr, host, sizeof host);
    port = ntohs(v4->sin_port);
  } else if (a.ss_family == AF_INET6) {
    const auto* v6 = reinterpret_cast<const sockaddr_in6*>(&a);
    inet_ntop(AF_INET6, &v6->sin6_addr, host, sizeof host);
    port = ntohs(v6->sin6_port);
  }
  return std::string(host) + ":" + std::to_string(port);
}

std::string address_text(const sockaddr_storage& a) {
  const std::string s = endpoint_text(a);
  return s.substr(0, s.rfind(':'));
}

int remaining_ms(Clock::time_point deadline) {
  const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
  return static_cast<int>(std::max<int64_t>(0, left.count()));
}

}  // namespace

namespace detail {

void recv_exact(int fd, std::span<uint8_t> data, int timeout_ms, const std::atomic<bool>& shut) {
  const auto deadline = Clock::now() + std::chrono::milliseconds(std::max(timeout_ms, 0));
  size_t done = 0;
  while (done < data.size()) {
    if (shut) throw Error("connection shut down");
    const ssize_t n = ::recv(fd, data.data() + done, data.size() - done, 0);
    if (n > 0) {
      done += static_cast<size_t>(n);
      continue;
    }
    if (n == 0) throw Error(shut ? "connection shut down" : "peer closed the connection");
    if (errno == EINTR) continue;
    if (errno != EAGAIN && errno != EWOULDBLOCK) throw Error("read failed: " + errno_text());
    if (timeout_ms >= 0 && Clock::now() >= deadline) throw Error("timed out waiting for the peer");
    // Wake at least every 100 ms to notice shutdown (the socket's shutdown also wakes poll).
    pollfd p{fd, POLLIN, 0};
    ::poll(&p, 1, timeout_ms < 0 ? 100 : std::min(remaining_ms(deadline), 100));
  }
}

void send_all(int fd, iovec* iov, size_t count, int stall_ms, const std::atomic<bool>& shut) {
  size_t total = 0;
  for (size_t i = 0; i < count; ++i) total += iov[i].iov_len;
  auto last_progress = Clock::now();
  size_t first = 0;
  while (total > 0) {
    if (shut) throw Error("connection shut down");
    msghdr msg{};
    msg.msg_iov = iov + first;
    msg.msg_iovlen = count - first;
    const ssize_t n = ::sendmsg(fd, &msg, MSG_NOSIGNAL);
    if (n > 0) {
      size_t left = static_cast<size_t>(n);
      total -= left;
      while (left > 0) {  // advance past what was written
        if (left >= iov[first].iov_len) {
          left -= iov[first].iov_len;
          ++first;
        } else {
          iov[first].iov_base = static_cast<uint8_t*>(iov[first].iov_base) + left;
          iov[first].iov_len -= left;
          left = 0;
        }
      }
      last_progress = Clock::now();
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK)
      throw Error(shut ? "connection shut down" : "write failed: " + errno_text());
    const auto deadline = last_progress + std::chrono::milliseconds(stall_ms);
    if (Clock::now() >= deadline)
      throw Error("peer stalled: accepted no data for " + std::to_string(stall_ms) + " ms");
    pollfd p{fd, POLLOUT, 0};
    ::poll(&p, 1, std::min(remaining_ms(deadline), 100));
  }
}

}  // namespace detail

namespace {

class TcpConnection final : public Connection {
 public:
  TcpConnection(int fd, std::string peer) : fd_(fd), peer_(std::move(peer)) {
    configure_stream_socket(fd_);
  }

  size_t read_available(std::span<uint8_t> data) override {
    while (true) {
      check_open();
      const ssize_t n = ::recv(fd_, data.data(), data.size(), 0);
      if (n > 0) return static_cast<size_t>(n);
      if (n == 0) throw Error(shut_ ? "connection shut down" : "peer closed the connection");
      if (errno == EINTR) continue;
      if (errno == EAGAIN || errno == EWOULDBLOCK) return 0;
      throw Error("read failed: " + errno_text());
    }
  }

  int handshake_step() override { return 0; }
  int fd() const override { return fd_; }
  ~TcpConnection() override { ::close(fd_); }

  void read_exact(std::span<uint8_t> data, int timeout_ms) override {
    detail::recv_exact(fd_, data, timeout_ms, shut_);
  }
  void read_raw(std::span<uint8_t> data, int timeout_ms) override {
    detail::recv_exact(fd_, data, timeout_ms, shut_);
  }

  void write_all(std::span<const std::span<const uint8_t>> parts, int stall_ms) override {
    write_with_raw(parts, {}, stall_ms);
  }

  void write_with_raw(std::span<const std::span<const uint8_t>> parts, std::span<const uint8_t> raw,
                      int stall_ms) override {
    constexpr size_t kMaxParts = 16;
    if (parts.size() + 1 > kMaxParts) throw Error("write_all: too many parts");
    iovec iov[kMaxParts];
    size_t count = 0;
    for (const auto& p : parts)
      if (!p.empty()) iov[count++] = {const_cast<uint8_t*>(p.data()), p.size()};
    if (!raw.empty()) iov[count++] = {const_cast<uint8_t*>(raw.data()), raw.size()};
    detail::send_all(fd_, iov, count, stall_ms, shut_);
  }

  bool encrypted() const override { return false; }

  Ready wait(int wake_fd, int timeout_ms) override {
    check_open();
    pollfd p[2] = {{fd_, POLLIN, 0}, {wake_fd, POLLIN, 0}};
    const int n = ::poll(p, wake_fd >= 0 ? 2 : 1, timeout_ms);
    Ready r;
    if (n > 0) {
      r.readable = p[0].revents != 0;
      r.woken = wake_fd >= 0 && p[1].revents != 0;
    }
    return r;
  }

  std::string peer() const override { return peer_; }

  void shutdown() override {
    if (shut_.exchange(true)) return;
    ::shutdown(fd_, SHUT_RDWR);  // wakes poll() in other threads
  }

 private:
  void check_open() const {
    if (shut_) throw Error("connection shut down");
  }

  int fd_;
  std::string peer_;
  std::atomic<bool> shut_{false};
};

}  // namespace

void configure_stream_socket(int fd) {
  const int one = 1;
  ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  // BBR keeps throughput on lossy long paths where loss-based control collapses; best effort.
  static const char kBbr[] = "bbr";
  ::setsockopt(fd, IPPROTO_TCP, TCP_CONGESTION, kBbr, sizeof kBbr - 1);
  // Keepalive: probe after 10 s of silence, every 3 s, give up after 3 unanswered probes; and never
  // wait more than 20 s for unacknowledged data (a peer that vanished without a FIN).
  const int idle = 10, interval = 3, probes = 3;
  const unsigned user_timeout_ms = 20000;
  ::setsockopt(fd, SOL_SOCKET, SO_KEEPALIVE, &one, sizeof one);
  ::setsockopt(fd, IPPROTO_TCP, TCP_KEEPIDLE, &idle, sizeof idle);
  ::setsockopt(fd, IPPROTO_TCP, TCP_KEEPINTVL, &interval, sizeof interval);
  ::setsockopt(fd, IPPROTO_TCP, TCP_KEEPCNT, &probes, sizeof probes);
  ::setsockopt(fd, IPPROTO_TCP, TCP_USER_TIMEOUT, &user_timeout_ms, sizeof user_timeout_ms);
  const int flags = ::fcntl(fd, F_GETFL);
  ::fcntl(fd, F_SETFL, flags | O_NONBLOCK);
}

std::unique_ptr<Connection> make_tcp_connection(int fd, std::string peer) {
  return std::make_unique<TcpConnection>(fd, std::move(peer));
}

std::unique_ptr<Connection> connect_tcp(const std::string& host, uint16_t port, int timeout_ms) {
  const std::string where = host + ":" + std::to_string(port);
  const auto deadline = Clock::now() + std::chrono::milliseconds(std::max(timeout_ms, 1));
  asio::io_context io;
  asio::ip::tcp::resolver resolver(io);
  asio::error_code ec;
  const auto results = resolver.resolve(host, std::to_string(port), ec);
  if (ec) throw Error("cannot connect to " + where + ": " + ec.message());
  std::string why = "no address";
  for (const auto& r : results) {
    const auto ep = r.endpoint();
    const int fd = ::socket(ep.protocol().family(), SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
    if (fd < 0) {
      why = errno_text();
      continue;
    }
    int rc = ::connect(fd, ep.data(), static_cast<socklen_t>(ep.size()));
    if (rc != 0 && errno == EINPROGRESS) {
      pollfd p{fd, POLLOUT, 0};
      int n;
      do {
        n = ::poll(&p, 1, remaining_ms(deadline));
      } while (n < 0 && errno == EINTR);
      int err = 0;
      socklen_t len = sizeof err;
      if (n == 0) {
        err = ETIMEDOUT;
      } else {
        ::getsockopt(fd, SOL_SOCKET, SO_ERROR, &err, &len);
      }
      rc = err == 0 ? 0 : -1;
      errno = err;
    }
    if (rc == 0) {
      const std::string peer = ep.address().to_string() + ":" + std::to_string(ep.port());
      return std::make_unique<TcpConnection>(fd, peer);
    }
    why =
        errno == ETIMEDOUT ? "timed out after " + std::to_string(timeout_ms) + " ms" : errno_text();
    ::close(fd);
    if (Clock::now() >= deadline) break;
  }
  throw Error("cannot connect to " + where + ": " + why);
}

namespace {

// The addresses `host` names: itself if it is an IP address, else what the resolver returns
// (empty if it cannot be resolved).
std::vector<asio::ip::address> addresses_of(const std::string& host) {
  asio::error_code ec;
  const asio::ip::address literal = asio::ip::make_address(host, ec);
  if (!ec) return {literal};
  asio::io_context io;
  asio::ip::tcp::resolver resolver(io);
  std::vector<asio::ip::address> out;
  for (const auto& r : resolver.resolve(host, "", ec)) out.push_back(r.endpoint().address());
  return out;
}

}  // namespace

std::string resolve_bind_address(const std::string& host) {
  const auto addresses = addresses_of(host);
  if (addresses.empty()) throw Error("cannot listen on " + host + ": unknown host name");
  for (const auto& a : addresses)
    if (a.is_v4()) return a.to_string();
  return addresses.front().to_string();
}

bool is_loopback_address(const std::string& host) {
  const auto addresses = addresses_of(host);
  return !addresses.empty() &&
         std::ranges::all_of(addresses, [](const asio::ip::address& a) { return a.is_loopback(); });
}

TcpListener::TcpListener(const std::string& bind_address, uint16_t port) {
  const std::string where = bind_address + ":" + std::to_string(port);
  const asio::ip::address address = asio::ip::make_address(resolve_bind_address(bind_address));
  const asio::ip::tcp::endpoint ep(address, port);
  fd_ = ::socket(ep.protocol().family(), SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (fd_ < 0) throw Error("cannot listen on " + where + ": " + errno_text());
  const int one = 1;
  ::setsockopt(fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  if (::bind(fd_, ep.data(), static_cast<socklen_t>(ep.size())) != 0 || ::listen(fd_, 256) != 0) {
    const std::string why = errno_text();
    ::close(fd_);
    throw Error("cannot listen on " + where + ": " + why);
  }
  sockaddr_storage local{};
  socklen_t len = sizeof local;
  ::getsockname(fd_, reinterpret_cast<sockaddr*>(&local), &len);
  port_ = local.ss_family == AF_INET6 ? ntohs(reinterpret_cast<sockaddr_in6*>(&local)->sin6_port)
                                      : ntohs(reinterpret_cast<sockaddr_in*>(&local)->sin_port);
}

TcpListener::~TcpListener() {
  close();
  ::close(fd_);
}

uint16_t TcpListener::port() const {
  return port_;
}

std::unique_ptr<Connection> TcpListener::accept() {
  while (!closed_) {
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, 100) <= 0) continue;
    sockaddr_storage peer{};
    socklen_t len = sizeof peer;
    const int fd = ::accept4(fd_, reinterpret_cast<sockaddr*>(&peer), &len, SOCK_CLOEXEC);
    if (closed_) {
      if (fd >= 0) ::close(fd);
      break;
    }
    if (fd < 0) {
      // EMFILE and friends: back off instead of spinning; the listener stays up.
      if (errno != EAGAIN && errno != EINTR && errno != ECONNABORTED)
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
      continue;
    }
    return std::make_unique<TcpConnection>(fd, endpoint_text(peer));
  }
  return nullptr;
}

AcceptedSocket TcpListener::accept_nonblocking() {
  AcceptedSocket out;
  if (closed_) return out;
  sockaddr_storage peer{};
  socklen_t len = sizeof peer;
  const int fd =
      ::accept4(fd_, reinterpret_cast<sockaddr*>(&peer), &len, SOCK_CLOEXEC | SOCK_NONBLOCK);
  if (fd < 0) return out;  // nothing waiting, or a transient failure (EMFILE): the caller polls on
  out.fd = fd;
  out.peer = endpoint_text(peer);
  out.address = address_text(peer);
  return out;
}

void TcpListener::close() {
  if (closed_.exchange(true)) return;
  ::shutdown(fd_, SHUT_RDWR);
}

}  // namespace volcast
