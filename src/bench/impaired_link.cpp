// The impaired link: namespace and TUN set-up with ioctls, the relay thread, the impairment queue.
#include "volcast/bench/impaired_link.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <linux/if_tun.h>
#include <net/if.h>
#include <netinet/in.h>
#include <poll.h>
#include <sched.h>
#include <sys/eventfd.h>
#include <sys/ioctl.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>

#include "volcast/core/error.hpp"

namespace volcast {
namespace {

constexpr const char* kTunName = "vctun0";
constexpr int kMtu = 1500;
constexpr const char* kServerAddress = "10.77.0.1";
constexpr const char* kClientAddress = "10.77.0.2";

std::string errno_text(const std::string& what, int err) {
  return what + ": " + std::strerror(err) + " (errno " + std::to_string(err) + ")";
}

[[noreturn]] void throw_errno(const std::string& what, int err = errno) {
  throw Error("impaired link: " + errno_text(what, err));
}

/// Closes an fd when it goes out of scope unless released.
class Fd {
 public:
  explicit Fd(int fd = -1) : fd_(fd) {}
  ~Fd() {
    if (fd_ >= 0) ::close(fd_);
  }
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  int get() const { return fd_; }
  int release() { return std::exchange(fd_, -1); }

 private:
  int fd_;
};

uint64_t splitmix64(uint64_t& state) {
  uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

void validate(const LinkImpairment& imp) {
  if (imp.one_way_delay_us < 0) throw Error("impaired link: one_way_delay_us must be >= 0");
  if (!(imp.loss >= 0 && imp.loss <= 1)) throw Error("impaired link: loss must be in [0, 1]");
  if (!(imp.rate_bits_per_s >= 0) || !std::isfinite(imp.rate_bits_per_s))
    throw Error("impaired link: rate_bits_per_s must be finite and >= 0 (0 = unlimited)");
}

// ---- namespace set-up (runs on a short-lived thread that unshares its network namespace) ----

/// Writes a sysctl of the calling thread's network namespace (/proc/sys/net resolves to the
/// namespace of the thread that opens it). False if it cannot (no IPv6, read-only /proc/sys).
bool write_sysctl(const char* path, const char* value) {
  Fd fd(::open(path, O_WRONLY | O_CLOEXEC));
  if (fd.get() < 0) return false;
  const auto n = static_cast<ssize_t>(std::strlen(value));
  return ::write(fd.get(), value, static_cast<size_t>(n)) == n;
}

ifreq make_ifreq(const char* name) {
  ifreq ifr{};
  std::strncpy(ifr.ifr_name, name, IFNAMSIZ - 1);
  return ifr;
}

sockaddr make_inet(const char* address) {
  sockaddr_in in{};
  in.sin_family = AF_INET;
  if (::inet_pton(AF_INET, address, &in.sin_addr) != 1)
    throw Error(std::string("impaired link: bad IPv4 address ") + address);
  sockaddr out{};
  static_assert(sizeof(in) <= sizeof(out));
  std::memcpy(&out, &in, sizeof(in));
  return out;
}

void interface_ioctl(int sock, unsigned long request, const char* request_name, ifreq& ifr) {
  if (::ioctl(sock, request, &ifr) != 0)
    throw_errno(std::string("ioctl(") + request_name + ", " + ifr.ifr_name + ")");
}

void bring_up(int sock, const char* name) {
  ifreq ifr = make_ifreq(name);
  interface_ioctl(sock, SIOCGIFFLAGS, "SIOCGIFFLAGS", ifr);
  ifr.ifr_flags = static_cast<short>(ifr.ifr_flags | IFF_UP | IFF_RUNNING);
  interface_ioctl(sock, SIOCSIFFLAGS, "SIOCSIFFLAGS", ifr);
}

struct NamespaceSetup {
  int ns_fd = -1;
  int tun_fd = -1;
  bool ipv6_disabled = false;
  bool unsupported = false;  // the machine cannot do it (permissions, no TUN): skip, not fail
  std::string error;
};

/// On the calling (dedicated) thread: a new network namespace with lo up and a TUN device
/// `local` <-> `peer` (/32 point-to-point, MTU 1500, up).
void set_up_namespace(const char* local, const char* peer, NamespaceSetup& out) {
  if (::unshare(CLONE_NEWNET) != 0) {
    out.unsupported = true;
    out.error = errno_text("unshare(CLONE_NEWNET)", errno) +
                " - needs CAP_SYS_ADMIN (run the test as root)";
    return;
  }
  Fd ns(::open("/proc/thread-self/ns/net", O_RDONLY | O_CLOEXEC));
  if (ns.get() < 0) {
    out.unsupported = true;
    out.error = errno_text("open(/proc/thread-self/ns/net)", errno);
    return;
  }
  // IPv4 only: no IPv6 link-local address, DAD, router solicitations or MLD on the link.
  // Best effort: where /proc/sys is read-only the relay drops IPv6 instead (ipv6_disabled()).
  out.ipv6_disabled = write_sysctl("/proc/sys/net/ipv6/conf/all/disable_ipv6", "1") &&
                      write_sysctl("/proc/sys/net/ipv6/conf/default/disable_ipv6", "1");

  Fd sock(::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0));
  if (sock.get() < 0) throw_errno("socket(AF_INET, SOCK_DGRAM)");
  bring_up(sock.get(), "lo");

  Fd tun(::open("/dev/net/tun", O_RDWR | O_CLOEXEC | O_NONBLOCK));
  if (tun.get() < 0) {
    out.unsupported = true;
    out.error = errno_text("open(/dev/net/tun)", errno) +
                " - no usable TUN device (TUN driver, or the device node in this container)";
    return;
  }
  ifreq ifr = make_ifreq(kTunName);
  ifr.ifr_flags = IFF_TUN | IFF_NO_PI;
  if (::ioctl(tun.get(), TUNSETIFF, &ifr) != 0) {
    out.unsupported = errno == EPERM || errno == EACCES || errno == ENODEV;
    out.error = errno_text("ioctl(TUNSETIFF)", errno) + " - needs CAP_NET_ADMIN";
    return;
  }

  // Before the device is up, so no classful /8 route ever appears: address, /32, peer, MTU.
  ifr = make_ifreq(kTunName);
  ifr.ifr_addr = make_inet(local);
  interface_ioctl(sock.get(), SIOCSIFADDR, "SIOCSIFADDR", ifr);
  ifr = make_ifreq(kTunName);
  ifr.ifr_netmask = make_inet("255.255.255.255");
  interface_ioctl(sock.get(), SIOCSIFNETMASK, "SIOCSIFNETMASK", ifr);
  ifr = make_ifreq(kTunName);
  ifr.ifr_dstaddr = make_inet(peer);  // the kernel adds the route peer/32 dev vctun0
  interface_ioctl(sock.get(), SIOCSIFDSTADDR, "SIOCSIFDSTADDR", ifr);
  ifr = make_ifreq(kTunName);
  ifr.ifr_mtu = kMtu;
  interface_ioctl(sock.get(), SIOCSIFMTU, "SIOCSIFMTU", ifr);
  bring_up(sock.get(), kTunName);

  // Check the peer route: connect() on a UDP socket only looks the route up.
  sockaddr to = make_inet(peer);
  reinterpret_cast<sockaddr_in*>(&to)->sin_port = htons(9);
  Fd probe(::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0));
  if (probe.get() < 0) throw_errno("socket(AF_INET, SOCK_DGRAM)");
  if (::connect(probe.get(), &to, sizeof(sockaddr_in)) != 0)
    throw_errno(std::string("connect(UDP ") + peer + ") - no route to the peer");

  out.ns_fd = ns.release();
  out.tun_fd = tun.release();
}

NamespaceSetup make_namespace(const char* local, const char* peer) {
  NamespaceSetup out;
  // A thread of its own: unshare() moves only the calling thread, which then simply ends; the
  // namespace lives on through the fds.
  std::thread worker([&] {
    try {
      set_up_namespace(local, peer, out);
    } catch (const std::exception& e) {
      out.error = e.what();
    }
  });
  worker.join();
  if (out.error.empty() && out.ns_fd < 0) out.error = "impaired link: namespace set-up failed";
  return out;
}

}  // namespace

// ---------------------------------- ImpairmentQueue ----------------------------------

ImpairmentQueue::ImpairmentQueue(const LinkImpairment& impairment, uint64_t stream)
    : impairment_(impairment), rng_state_(impairment.seed ^ (stream * 0xD1B54A32D192ED03ull)) {
  validate(impairment);
}

void ImpairmentQueue::set_impairment(const LinkImpairment& impairment) {
  validate(impairment);
  impairment_ = impairment;
}

double ImpairmentQueue::next_uniform() {
  return static_cast<double>(splitmix64(rng_state_) >> 11) * 0x1.0p-53;
}

size_t ImpairmentQueue::backlog_bytes(Clock::time_point t) const {
  if (impairment_.rate_bits_per_s <= 0 || bottleneck_free_ <= t) return 0;
  const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(bottleneck_free_ - t);
  return static_cast<size_t>(
      std::ceil(static_cast<double>(ns.count()) * impairment_.rate_bits_per_s / 8e9));
}

ImpairmentQueue::Verdict ImpairmentQueue::push(std::vector<uint8_t> packet,
                                               Clock::time_point arrival) {
  if (impairment_.loss > 0 && next_uniform() < impairment_.loss) return Verdict::kLost;
  Clock::time_point done = arrival;
  if (impairment_.rate_bits_per_s > 0) {
    const size_t backlog = backlog_bytes(arrival);
    if (backlog > 0 && backlog + packet.size() > impairment_.queue_bytes)
      return Verdict::kQueueFull;
    const auto serialize = std::chrono::duration_cast<Clock::duration>(std::chrono::nanoseconds(
        std::llround(static_cast<double>(packet.size()) * 8e9 / impairment_.rate_bits_per_s)));
    done = std::max(arrival, bottleneck_free_) + serialize;
    bottleneck_free_ = done;
  }
  const Clock::time_point release =
      std::max(done + std::chrono::microseconds(impairment_.one_way_delay_us), last_release_);
  last_release_ = release;
  queue_.push_back({release, std::move(packet)});
  return Verdict::kQueued;
}

std::optional<ImpairmentQueue::Clock::time_point> ImpairmentQueue::next_release() const {
  if (queue_.empty()) return std::nullopt;
  return queue_.front().release;
}

bool ImpairmentQueue::pop_due(Clock::time_point now, std::vector<uint8_t>& out) {
  if (queue_.empty() || queue_.front().release > now) return false;
  out = std::move(queue_.front().packet);
  queue_.pop_front();
  return true;
}

// ----------------------------------- ImpairedLink -----------------------------------

std::unique_ptr<ImpairedLink> ImpairedLink::create(const LinkImpairment& both_ways,
                                                   std::string* why_not) {
  return create(both_ways, both_ways, why_not);
}

std::unique_ptr<ImpairedLink> ImpairedLink::create(const LinkImpairment& server_to_client,
                                                   const LinkImpairment& client_to_server,
                                                   std::string* why_not) {
  std::unique_ptr<ImpairedLink> link(new ImpairedLink());
  link->to_client_ = std::make_unique<Direction>(server_to_client, 0);  // validates
  link->to_server_ = std::make_unique<Direction>(client_to_server, 1);

  link->ipv6_disabled_ = true;
  for (const bool server : {true, false}) {
    NamespaceSetup ns = server ? make_namespace(kServerAddress, kClientAddress)
                               : make_namespace(kClientAddress, kServerAddress);
    if (ns.ns_fd < 0) {
      const std::string what = std::string("impaired link: ") + (server ? "server" : "client") +
                               " namespace: " + ns.error;
      if (!ns.unsupported) throw Error(what);
      if (why_not) *why_not = what;
      return nullptr;
    }
    (server ? link->server_ns_fd_ : link->client_ns_fd_) = ns.ns_fd;
    (server ? link->server_tun_fd_ : link->client_tun_fd_) = ns.tun_fd;
    link->ipv6_disabled_ = link->ipv6_disabled_ && ns.ipv6_disabled;
  }
  link->stop_fd_ = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (link->stop_fd_ < 0) throw_errno("eventfd");
  link->relay_ = std::thread([l = link.get()] { l->relay(); });
  return link;
}

ImpairedLink::~ImpairedLink() {
  if (relay_.joinable()) {
    const uint64_t one = 1;
    if (::write(stop_fd_, &one, sizeof(one)) != static_cast<ssize_t>(sizeof(one)))
      std::fprintf(stderr, "impaired link: %s\n", errno_text("write(eventfd)", errno).c_str());
    relay_.join();
  }
  // Closing the (non-persistent) TUN fds deletes the devices; the namespaces go with the last fd.
  for (int fd : {server_tun_fd_, client_tun_fd_, server_ns_fd_, client_ns_fd_, stop_fd_})
    if (fd >= 0) ::close(fd);
}

void ImpairedLink::run_in_namespace(int ns_fd, const char* name, const std::function<void()>& f) {
  Fd original(::open("/proc/thread-self/ns/net", O_RDONLY | O_CLOEXEC));
  if (original.get() < 0) throw_errno("open(/proc/thread-self/ns/net)");
  if (::setns(ns_fd, CLONE_NEWNET) != 0)
    throw_errno(std::string("setns(") + name + " namespace, CLONE_NEWNET)");
  const auto restore = [&]() -> int {
    return ::setns(original.get(), CLONE_NEWNET) == 0 ? 0 : errno;
  };
  try {
    f();
  } catch (...) {
    if (const int err = restore()) {
      std::fprintf(stderr,
                   "impaired link: %s while an exception left the %s namespace; this thread would "
                   "stay in it, terminating\n",
                   errno_text("setns(original namespace, CLONE_NEWNET)", err).c_str(), name);
      std::terminate();
    }
    throw;
  }
  if (const int err = restore())
    throw Error("impaired link: " + errno_text("setns(original namespace, CLONE_NEWNET)", err) +
                " - the calling thread is still in the " + name + " namespace");
}

LinkCounters ImpairedLink::counters() const {
  std::lock_guard lock(mutex_);
  return {to_client_->counters, to_server_->counters};
}

void ImpairedLink::set_impairment(const LinkImpairment& server_to_client,
                                  const LinkImpairment& client_to_server) {
  validate(server_to_client);
  validate(client_to_server);
  std::lock_guard lock(mutex_);
  to_client_->queue.set_impairment(server_to_client);
  to_server_->queue.set_impairment(client_to_server);
}

void ImpairedLink::relay() {
  using RelayClock = ImpairmentQueue::Clock;
  ::prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL);  // wake at the release time, not 50 us later
  std::vector<uint8_t> buffer(65536);
  std::vector<uint8_t> packet;
  struct Path {
    int from;
    int to;
    Direction* direction;
  };
  const std::array<Path, 2> paths{Path{server_tun_fd_, client_tun_fd_, to_client_.get()},
                                  Path{client_tun_fd_, server_tun_fd_, to_server_.get()}};
  std::array<pollfd, 3> fds{pollfd{server_tun_fd_, POLLIN, 0}, pollfd{client_tun_fd_, POLLIN, 0},
                            pollfd{stop_fd_, POLLIN, 0}};
  for (;;) {
    // Send what is due, then sleep until the next release or a new packet.
    std::optional<RelayClock::time_point> next;
    {
      std::lock_guard lock(mutex_);
      const RelayClock::time_point now = RelayClock::now();
      for (const Path& p : paths) {
        while (p.direction->queue.pop_due(now, packet)) {
          const ssize_t n = ::write(p.to, packet.data(), packet.size());
          DirectionCounters& c = p.direction->counters;
          if (n == static_cast<ssize_t>(packet.size())) {
            ++c.packets_forwarded;
            c.bytes_forwarded += packet.size();
          } else {
            ++c.write_errors;
          }
        }
        const auto release = p.direction->queue.next_release();
        if (release && (!next || *release < *next)) next = release;
      }
    }
    timespec timeout{};
    timespec* timeout_ptr = nullptr;
    if (next) {
      const auto wait = std::max(RelayClock::duration::zero(), *next - RelayClock::now());
      const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(wait).count();
      timeout.tv_sec = static_cast<time_t>(ns / 1'000'000'000);
      timeout.tv_nsec = static_cast<long>(ns % 1'000'000'000);
      timeout_ptr = &timeout;
    }
    if (::ppoll(fds.data(), fds.size(), timeout_ptr, nullptr) < 0) {
      if (errno == EINTR) continue;
      std::fprintf(stderr, "impaired link: relay stops: %s\n", errno_text("ppoll", errno).c_str());
      return;
    }
    if (fds[2].revents != 0) return;  // stop
    for (size_t i = 0; i < paths.size(); ++i) {
      if (fds[i].revents & (POLLERR | POLLHUP | POLLNVAL)) {
        std::fprintf(stderr, "impaired link: relay stops: TUN fd error (revents %#x)\n",
                     static_cast<unsigned>(fds[i].revents));
        return;
      }
      if (!(fds[i].revents & POLLIN)) continue;
      // Bounded batch, so due packets are not held back by a flood in the other direction.
      for (int k = 0; k < 256; ++k) {
        const ssize_t n = ::read(paths[i].from, buffer.data(), buffer.size());
        if (n < 0) {
          if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) break;
          std::fprintf(stderr, "impaired link: relay stops: %s\n",
                       errno_text("read(TUN)", errno).c_str());
          return;
        }
        const auto size = static_cast<size_t>(n);
        const RelayClock::time_point arrival = RelayClock::now();
        std::lock_guard lock(mutex_);
        DirectionCounters& c = paths[i].direction->counters;
        if (size == 0 || (buffer[0] >> 4) != 4) {  // IPv4 only
          ++c.dropped_not_ipv4;
          continue;
        }
        ++c.packets_in;
        c.bytes_in += size;
        switch (paths[i].direction->queue.push(
            std::vector<uint8_t>(buffer.begin(), buffer.begin() + n), arrival)) {
          case ImpairmentQueue::Verdict::kQueued:
            break;
          case ImpairmentQueue::Verdict::kLost:
            ++c.dropped_loss;
            break;
          case ImpairmentQueue::Verdict::kQueueFull:
            ++c.dropped_queue;
            break;
        }
      }
    }
  }
}

}  // namespace volcast
