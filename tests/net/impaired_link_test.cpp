// The userspace impaired link (tests/support/impaired_link.hpp): the impairment queue's timing on
// its own, then TCP and UDP through real namespaces and TUN devices with delay, loss and a rate
// limit. Timing checks are lower bounds (the link cannot be faster than its impairment) with only
// generous upper bounds, because the machine running the tests is shared and loaded.
#include <arpa/inet.h>
#include <fcntl.h>
#include <linux/capability.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <numeric>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <vector>

#include "volcast/bench/impaired_link.hpp"
#include "volcast/core/error.hpp"

namespace volcast::test {
namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::microseconds;
using std::chrono::milliseconds;

// ------------------------------- ImpairmentQueue (no root) -------------------------------

std::vector<uint8_t> bytes(size_t n, uint8_t tag = 0) {
  return std::vector<uint8_t>(n, tag);
}

TEST(ImpairmentQueue, DelayHoldsEachPacketExactly) {
  ImpairmentQueue q({.one_way_delay_us = 20'000});
  const auto t0 = Clock::now();
  ASSERT_EQ(q.push(bytes(100), t0), ImpairmentQueue::Verdict::kQueued);
  ASSERT_EQ(q.push(bytes(100), t0 + milliseconds(1)), ImpairmentQueue::Verdict::kQueued);
  EXPECT_EQ(q.next_release(), t0 + milliseconds(20));
  std::vector<uint8_t> out;
  EXPECT_FALSE(q.pop_due(t0 + milliseconds(20) - std::chrono::nanoseconds(1), out));
  EXPECT_TRUE(q.pop_due(t0 + milliseconds(20), out));
  EXPECT_EQ(q.next_release(), t0 + milliseconds(21));
  EXPECT_FALSE(q.pop_due(t0 + milliseconds(20), out));
  EXPECT_TRUE(q.pop_due(t0 + milliseconds(21), out));
  EXPECT_FALSE(q.next_release().has_value());
}

TEST(ImpairmentQueue, RateSerializesBackToBackPackets) {
  // 1 Mbit/s: a 1250-byte packet takes 10 ms on the wire, then 5 ms of delay.
  ImpairmentQueue q({.one_way_delay_us = 5'000, .rate_bits_per_s = 1e6});
  const auto t0 = Clock::now();
  for (int i = 0; i < 3; ++i) ASSERT_EQ(q.push(bytes(1250), t0), ImpairmentQueue::Verdict::kQueued);
  EXPECT_EQ(q.backlog_bytes(t0), 3750u);
  EXPECT_EQ(q.backlog_bytes(t0 + milliseconds(25)), 625u);
  std::vector<uint8_t> out;
  for (int i = 1; i <= 3; ++i) {
    EXPECT_EQ(q.next_release(), t0 + milliseconds(10 * i + 5));
    EXPECT_TRUE(q.pop_due(t0 + milliseconds(10 * i + 5), out));
  }
  // An idle link starts again from the arrival time.
  const auto t1 = t0 + milliseconds(100);
  ASSERT_EQ(q.push(bytes(125), t1), ImpairmentQueue::Verdict::kQueued);
  EXPECT_EQ(q.next_release(), t1 + milliseconds(1) + milliseconds(5));
}

TEST(ImpairmentQueue, FullBottleneckTailDrops) {
  ImpairmentQueue q({.rate_bits_per_s = 1e6, .queue_bytes = 3000});
  const auto t0 = Clock::now();
  EXPECT_EQ(q.push(bytes(1000), t0), ImpairmentQueue::Verdict::kQueued);
  EXPECT_EQ(q.push(bytes(1000), t0), ImpairmentQueue::Verdict::kQueued);
  EXPECT_EQ(q.push(bytes(1000), t0), ImpairmentQueue::Verdict::kQueued);
  EXPECT_EQ(q.push(bytes(1000), t0), ImpairmentQueue::Verdict::kQueueFull);
  EXPECT_EQ(q.size(), 3u);
  // 8 ms later 1000 bytes have left: room for one more.
  EXPECT_EQ(q.push(bytes(1000), t0 + milliseconds(8)), ImpairmentQueue::Verdict::kQueued);
  EXPECT_EQ(q.push(bytes(1000), t0 + milliseconds(8)), ImpairmentQueue::Verdict::kQueueFull);
  // A packet larger than the queue still goes through an idle bottleneck.
  ImpairmentQueue small({.rate_bits_per_s = 1e6, .queue_bytes = 100});
  EXPECT_EQ(small.push(bytes(1500), t0), ImpairmentQueue::Verdict::kQueued);
  EXPECT_EQ(small.push(bytes(50), t0), ImpairmentQueue::Verdict::kQueueFull);
}

std::vector<bool> loss_pattern(const LinkImpairment& imp, uint64_t stream, int n) {
  ImpairmentQueue q(imp, stream);
  std::vector<bool> lost;
  const auto t0 = Clock::now();
  for (int i = 0; i < n; ++i) {
    lost.push_back(q.push(bytes(1), t0) == ImpairmentQueue::Verdict::kLost);
    std::vector<uint8_t> out;
    q.pop_due(t0, out);
  }
  return lost;
}

TEST(ImpairmentQueue, LossIsSeededAndHasTheRequestedRate) {
  const int n = 100'000;
  const auto a = loss_pattern({.loss = 0.1, .seed = 7}, 0, n);
  const double rate = static_cast<double>(std::count(a.begin(), a.end(), true)) / n;
  EXPECT_NEAR(rate, 0.1, 0.005);
  EXPECT_EQ(a, loss_pattern({.loss = 0.1, .seed = 7}, 0, n));  // deterministic
  EXPECT_NE(a, loss_pattern({.loss = 0.1, .seed = 8}, 0, n));
  EXPECT_NE(a, loss_pattern({.loss = 0.1, .seed = 7}, 1, n));  // the other direction's stream
  const auto none = loss_pattern({.loss = 0}, 0, 1000);
  const auto all = loss_pattern({.loss = 1}, 0, 1000);
  EXPECT_EQ(std::count(none.begin(), none.end(), true), 0);
  EXPECT_EQ(std::count(all.begin(), all.end(), true), 1000);
}

TEST(ImpairmentQueue, PacketsStayInOrderWhenTheDelayShrinks) {
  ImpairmentQueue q({.one_way_delay_us = 50'000});
  const auto t0 = Clock::now();
  q.push(bytes(10, 1), t0);
  q.set_impairment({.one_way_delay_us = 0});
  q.push(bytes(10, 2), t0 + milliseconds(1));
  std::vector<uint8_t> out;
  EXPECT_FALSE(q.pop_due(t0 + milliseconds(2), out));  // 2 waits behind 1
  ASSERT_TRUE(q.pop_due(t0 + milliseconds(50), out));
  EXPECT_EQ(out[0], 1);
  ASSERT_TRUE(q.pop_due(t0 + milliseconds(50), out));
  EXPECT_EQ(out[0], 2);
}

TEST(ImpairmentQueue, RejectsNonsense) {
  EXPECT_THROW(ImpairmentQueue({.one_way_delay_us = -1}), Error);
  EXPECT_THROW(ImpairmentQueue({.loss = 1.5}), Error);
  EXPECT_THROW(ImpairmentQueue({.loss = std::nan("")}), Error);
  EXPECT_THROW(ImpairmentQueue({.rate_bits_per_s = -5}), Error);
}

// ----------------------------- sockets through the link (root) -----------------------------

/// Owns a socket fd.
class Socket {
 public:
  explicit Socket(int fd = -1) : fd_(fd) {}
  ~Socket() {
    if (fd_ >= 0) ::close(fd_);
  }
  Socket(Socket&& o) noexcept : fd_(std::exchange(o.fd_, -1)) {}
  Socket& operator=(Socket&& o) noexcept {
    std::swap(fd_, o.fd_);
    return *this;
  }
  int fd() const { return fd_; }

 private:
  int fd_;
};

[[noreturn]] void fail(const std::string& what) {
  throw std::runtime_error(what + ": " + std::strerror(errno));
}

sockaddr_in inet(const std::string& address, uint16_t port) {
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(port);
  if (::inet_pton(AF_INET, address.c_str(), &a.sin_addr) != 1) fail("inet_pton " + address);
  return a;
}

uint16_t local_port(const Socket& s) {
  sockaddr_in a{};
  socklen_t len = sizeof(a);
  if (::getsockname(s.fd(), reinterpret_cast<sockaddr*>(&a), &len) != 0) fail("getsockname");
  return ntohs(a.sin_port);
}

void set_timeouts(const Socket& s, int seconds) {
  timeval tv{seconds, 0};
  ::setsockopt(s.fd(), SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof(tv));
  ::setsockopt(s.fd(), SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof(tv));
}

/// A TCP listener on `address`, any port (call inside the server namespace).
Socket tcp_listen(const std::string& address) {
  Socket s(::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0));
  if (s.fd() < 0) fail("socket");
  const sockaddr_in a = inet(address, 0);
  if (::bind(s.fd(), reinterpret_cast<const sockaddr*>(&a), sizeof(a)) != 0) fail("bind");
  if (::listen(s.fd(), 4) != 0) fail("listen");
  return s;
}

Socket tcp_accept(const Socket& listener) {
  pollfd p{listener.fd(), POLLIN, 0};
  if (::poll(&p, 1, 60'000) != 1) throw std::runtime_error("no connection within 60 s");
  Socket s(::accept4(listener.fd(), nullptr, nullptr, SOCK_CLOEXEC));
  if (s.fd() < 0) fail("accept");
  set_timeouts(s, 60);
  return s;
}

/// A connected TCP socket (call inside the client namespace).
Socket tcp_connect(const std::string& address, uint16_t port) {
  Socket s(::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0));
  if (s.fd() < 0) fail("socket");
  set_timeouts(s, 60);
  const int one = 1;
  ::setsockopt(s.fd(), IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
  const sockaddr_in a = inet(address, port);
  if (::connect(s.fd(), reinterpret_cast<const sockaddr*>(&a), sizeof(a)) != 0) fail("connect");
  return s;
}

void send_all(const Socket& s, const uint8_t* data, size_t size) {
  while (size > 0) {
    const ssize_t n = ::send(s.fd(), data, size, MSG_NOSIGNAL);
    if (n <= 0) fail("send");
    data += n;
    size -= static_cast<size_t>(n);
  }
}

/// Reads until the peer closes; throws on a timeout.
std::vector<uint8_t> recv_to_end(const Socket& s) {
  std::vector<uint8_t> all;
  std::vector<uint8_t> chunk(1 << 16);
  for (;;) {
    const ssize_t n = ::recv(s.fd(), chunk.data(), chunk.size(), 0);
    if (n < 0) fail("recv");
    if (n == 0) return all;
    all.insert(all.end(), chunk.begin(), chunk.begin() + n);
  }
}

void recv_exact(const Socket& s, uint8_t* data, size_t size) {
  while (size > 0) {
    const ssize_t n = ::recv(s.fd(), data, size, 0);
    if (n <= 0) fail("recv");
    data += n;
    size -= static_cast<size_t>(n);
  }
}

std::vector<uint8_t> pattern(size_t n) {
  std::vector<uint8_t> v(n);
  uint32_t x = 12345;
  for (auto& b : v) {
    x = x * 1664525u + 1013904223u;
    b = static_cast<uint8_t>(x >> 24);
  }
  return v;
}

/// Sends `data` from the server namespace to the client namespace over TCP; returns what arrived
/// and the seconds from the client's connect() returning to the end of the stream.
std::pair<std::vector<uint8_t>, double> transfer_to_client(ImpairedLink& link,
                                                           const std::vector<uint8_t>& data) {
  Socket listener = link.in_server_namespace([&] { return tcp_listen(link.server_address()); });
  const uint16_t port = local_port(listener);
  std::string server_error;
  std::thread server([&] {
    try {
      Socket s = tcp_accept(listener);
      send_all(s, data.data(), data.size());
    } catch (const std::exception& e) {
      server_error = e.what();
    }
  });
  std::vector<uint8_t> got;
  double seconds = 0;
  try {
    Socket c = link.in_client_namespace([&] { return tcp_connect(link.server_address(), port); });
    const auto t0 = Clock::now();
    got = recv_to_end(c);
    seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "client: " << e.what();
  }
  server.join();
  EXPECT_EQ(server_error, "");
  return {std::move(got), seconds};
}

TEST(ImpairedLink, DelayAddsTwiceTheOneWayDelayToARoundTrip) {
  std::string why;
  auto link = ImpairedLink::create({.one_way_delay_us = 20'000}, &why);
  if (!link) GTEST_SKIP() << why;

  Socket listener = link->in_server_namespace([&] { return tcp_listen(link->server_address()); });
  const uint16_t port = local_port(listener);
  std::thread echo([&] {
    try {
      Socket s = tcp_accept(listener);
      const int one = 1;
      ::setsockopt(s.fd(), IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
      uint8_t message[64];
      for (;;) {
        const ssize_t n = ::recv(s.fd(), message, sizeof(message), MSG_WAITALL);
        if (n <= 0) return;
        send_all(s, message, static_cast<size_t>(n));
      }
    } catch (const std::exception& e) {
      ADD_FAILURE() << "echo: " << e.what();
    }
  });

  const auto t_connect = Clock::now();
  Socket c = link->in_client_namespace([&] { return tcp_connect(link->server_address(), port); });
  EXPECT_GE(Clock::now() - t_connect, milliseconds(40)) << "the handshake is one round trip";
  std::vector<double> rtt_ms;
  uint8_t message[64];
  for (int i = 0; i < 10; ++i) {
    std::memset(message, i, sizeof(message));
    const auto t0 = Clock::now();
    send_all(c, message, sizeof(message));
    recv_exact(c, message, sizeof(message));
    rtt_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    EXPECT_EQ(message[63], i);
    EXPECT_GE(rtt_ms.back(), 40.0);
  }
  ::shutdown(c.fd(), SHUT_WR);
  echo.join();
  std::sort(rtt_ms.begin(), rtt_ms.end());
  EXPECT_LT(rtt_ms[rtt_ms.size() / 2], 1000.0);
  std::printf("RTT over 2 x 20 ms: min %.2f ms, median %.2f ms, max %.2f ms\n", rtt_ms.front(),
              rtt_ms[rtt_ms.size() / 2], rtt_ms.back());
  const LinkCounters n = link->counters();
  EXPECT_GE(n.client_to_server.packets_forwarded, 11u);  // SYN + 10 messages at least
  EXPECT_GE(n.server_to_client.packets_forwarded, 11u);
  for (const DirectionCounters& d : {n.client_to_server, n.server_to_client}) {
    EXPECT_EQ(d.dropped_loss + d.dropped_queue + d.write_errors, 0u);
    if (link->ipv6_disabled()) {
      EXPECT_EQ(d.dropped_not_ipv4, 0u) << "IPv6 should be off";
    }
  }
}

TEST(ImpairedLink, TcpDeliversEveryByteThroughTenPercentLoss) {
  std::string why;
  auto link = ImpairedLink::create({.one_way_delay_us = 1'000, .loss = 0.10, .seed = 42}, &why);
  if (!link) GTEST_SKIP() << why;
  const std::vector<uint8_t> data = pattern(2'000'000);
  const auto [got, seconds] = transfer_to_client(*link, data);
  EXPECT_EQ(got.size(), data.size());
  EXPECT_TRUE(got == data) << "the stream arrived corrupted";
  const LinkCounters n = link->counters();
  std::printf("2 MB through 10 %% loss in %.2f s; dropped %llu of %llu down, %llu of %llu up\n",
              seconds, static_cast<unsigned long long>(n.server_to_client.dropped_loss),
              static_cast<unsigned long long>(n.server_to_client.packets_in),
              static_cast<unsigned long long>(n.client_to_server.dropped_loss),
              static_cast<unsigned long long>(n.client_to_server.packets_in));
  EXPECT_GT(n.server_to_client.dropped_loss, 0u);
  EXPECT_GT(n.client_to_server.dropped_loss, 0u);
  EXPECT_GE(n.server_to_client.bytes_forwarded, data.size());  // payload plus headers, retransmits
}

TEST(ImpairedLink, RateLimitBoundsThroughput) {
  std::string why;
  const double rate = 20e6;
  auto link = ImpairedLink::create({.rate_bits_per_s = rate}, &why);
  if (!link) GTEST_SKIP() << why;
  const std::vector<uint8_t> data = pattern(5'000'000);
  const auto [got, seconds] = transfer_to_client(*link, data);
  EXPECT_TRUE(got == data);
  const double floor_s = static_cast<double>(data.size()) * 8 / rate;  // 2 s of payload alone
  const LinkCounters n = link->counters();
  std::printf(
      "5 MB at 20 Mbit/s in %.2f s (payload alone needs %.2f s): %.1f Mbit/s goodput, "
      "%llu tail drops\n",
      seconds, floor_s, static_cast<double>(data.size()) * 8 / seconds / 1e6,
      static_cast<unsigned long long>(n.server_to_client.dropped_queue));
  EXPECT_GE(seconds, floor_s - 0.05);
  EXPECT_LT(seconds, 120.0);
}

TEST(ImpairedLink, ShortBottleneckQueueTailDropsAndTcpRecovers) {
  // An 8 KiB queue is smaller than TCP's initial window (10 segments): the burst overflows it.
  std::string why;
  auto link = ImpairedLink::create(
      {.one_way_delay_us = 5'000, .rate_bits_per_s = 10e6, .queue_bytes = 8 * 1024}, &why);
  if (!link) GTEST_SKIP() << why;
  const std::vector<uint8_t> data = pattern(1'000'000);
  const auto [got, seconds] = transfer_to_client(*link, data);
  EXPECT_TRUE(got == data);
  const LinkCounters n = link->counters();
  std::printf("1 MB at 10 Mbit/s through an 8 KiB queue in %.2f s, %llu tail drops\n", seconds,
              static_cast<unsigned long long>(n.server_to_client.dropped_queue));
  EXPECT_GT(n.server_to_client.dropped_queue, 0u);
  EXPECT_EQ(n.server_to_client.dropped_loss, 0u);
  EXPECT_GE(seconds, 0.8 - 0.05);
}

TEST(ImpairedLink, UdpCountsMatchAndLossIsReproducible) {
  std::string why;
  const auto run = [&why](std::set<uint32_t>& received, LinkCounters& counters) -> bool {
    auto link = ImpairedLink::create({}, {.loss = 0.2, .seed = 99}, &why);  // loss upstream only
    if (!link) return false;
    Socket rx = link->in_server_namespace([&] {
      Socket s(::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0));
      const sockaddr_in a = inet(link->server_address(), 0);
      if (s.fd() < 0 || ::bind(s.fd(), reinterpret_cast<const sockaddr*>(&a), sizeof(a)) != 0)
        fail("udp bind");
      const int big = 4 << 20;
      ::setsockopt(s.fd(), SOL_SOCKET, SO_RCVBUFFORCE, &big, sizeof(big));
      return s;
    });
    Socket tx = link->in_client_namespace([] { return Socket(::socket(AF_INET, SOCK_DGRAM, 0)); });
    const sockaddr_in to = inet(link->server_address(), local_port(rx));
    for (uint32_t i = 0; i < 400; ++i) {
      if (::sendto(tx.fd(), &i, sizeof(i), 0, reinterpret_cast<const sockaddr*>(&to), sizeof(to)) !=
          sizeof(i))
        fail("sendto");
      if (i % 50 == 49) std::this_thread::sleep_for(milliseconds(2));  // never fill TUN queues
    }
    const auto deadline = Clock::now() + std::chrono::seconds(10);
    while (Clock::now() < deadline) {
      counters = link->counters();
      const auto& up = counters.client_to_server;
      if (up.packets_forwarded + up.dropped_loss == 400 && received.size() == up.packets_forwarded)
        break;
      pollfd p{rx.fd(), POLLIN, 0};
      if (::poll(&p, 1, 10) == 1) {
        uint32_t v = 0;
        if (::recv(rx.fd(), &v, sizeof(v), 0) == sizeof(v)) received.insert(v);
      }
    }
    return true;
  };
  std::set<uint32_t> first, second;
  LinkCounters a, b;
  if (!run(first, a)) GTEST_SKIP() << why;
  ASSERT_TRUE(run(second, b));
  EXPECT_EQ(a.client_to_server.packets_in, 400u);
  EXPECT_EQ(a.client_to_server.dropped_loss + a.client_to_server.packets_forwarded, 400u);
  EXPECT_EQ(first.size(), a.client_to_server.packets_forwarded);
  EXPECT_GT(a.client_to_server.dropped_loss, 40u);  // ~80 expected
  EXPECT_LT(a.client_to_server.dropped_loss, 120u);
  EXPECT_EQ(first, second) << "the same seed and packets must lose the same datagrams";
}

std::string read_text(const char* path) {
  std::ifstream f(path);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

ino_t current_net_namespace() {
  struct stat st {};
  if (::stat("/proc/thread-self/ns/net", &st) != 0) fail("stat /proc/thread-self/ns/net");
  return st.st_ino;
}

TEST(ImpairedLink, NamespaceCallsRestoreTheThreadsNamespace) {
  std::string why;
  auto link = ImpairedLink::create(LinkImpairment{}, &why);
  if (!link) GTEST_SKIP() << why;
  const ino_t home = current_net_namespace();
  const ino_t server = link->in_server_namespace(current_net_namespace);
  const ino_t client = link->in_client_namespace(current_net_namespace);
  EXPECT_NE(server, home);
  EXPECT_NE(client, home);
  EXPECT_NE(server, client);
  EXPECT_EQ(current_net_namespace(), home);
  EXPECT_EQ(link->in_server_namespace(current_net_namespace), server);
  // Nested, and through an exception.
  link->in_client_namespace([&] {
    EXPECT_EQ(link->in_server_namespace(current_net_namespace), server);
    EXPECT_EQ(current_net_namespace(), client);
  });
  EXPECT_THROW(link->in_server_namespace([] { throw std::logic_error("inside"); }),
               std::logic_error);
  EXPECT_EQ(current_net_namespace(), home);
  // Each side: exactly the /32 route to its peer (10.77.0.2 is 02004D0A in /proc/net/route), and
  // IPv6 off, while the host's own settings are untouched.
  link->in_server_namespace([&] {
    EXPECT_NE(read_text("/proc/thread-self/net/route").find("vctun0\t02004D0A\t00000000\t0005"),
              std::string::npos);
    if (link->ipv6_disabled()) {
      EXPECT_EQ(read_text("/proc/sys/net/ipv6/conf/vctun0/disable_ipv6"), "1\n");
    }
  });
  link->in_client_namespace([] {
    EXPECT_NE(read_text("/proc/thread-self/net/route").find("vctun0\t01004D0A\t00000000\t0005"),
              std::string::npos);
  });
  EXPECT_EQ(read_text("/proc/thread-self/net/route").find("vctun0"), std::string::npos);
  // Other threads never move.
  std::thread([&] { EXPECT_EQ(current_net_namespace(), home); }).join();
}

TEST(ImpairedLink, ReportsWhyNotWithoutPermission) {
  // The path every test takes on a machine without root: here forced by dropping CAP_SYS_ADMIN
  // and CAP_NET_ADMIN from one thread's effective set (the raw capset syscall changes only the
  // calling thread; the set-up thread create() starts inherits it). create() must return nullptr
  // with a reason naming the failed syscall, not throw.
  std::unique_ptr<ImpairedLink> link;
  std::string why;
  std::string error;
  std::thread([&] {
    __user_cap_header_struct header{_LINUX_CAPABILITY_VERSION_3, 0};
    __user_cap_data_struct caps[2]{};
    if (::syscall(SYS_capget, &header, caps) != 0) {
      error = std::string("capget: ") + std::strerror(errno);
      return;
    }
    for (const int cap : {CAP_SYS_ADMIN, CAP_NET_ADMIN})
      caps[cap / 32].effective &= ~(1u << (cap % 32));
    if (::syscall(SYS_capset, &header, caps) != 0) {
      error = std::string("capset: ") + std::strerror(errno);
      return;
    }
    try {
      link = ImpairedLink::create(LinkImpairment{}, &why);
    } catch (const std::exception& e) {
      error = std::string("threw: ") + e.what();
    }
  }).join();
  ASSERT_EQ(error, "");
  EXPECT_TRUE(link == nullptr);
  EXPECT_NE(why.find("unshare(CLONE_NEWNET)"), std::string::npos) << why;
  EXPECT_NE(why.find("Operation not permitted"), std::string::npos) << why;
  std::printf("why_not: %s\n", why.c_str());
}

}  // namespace
}  // namespace volcast::test
