#pragma once
// A userspace impaired network link (tests and `volcast bench --paths`): two private network
// namespaces ("server" and "client") joined by two TUN devices and a relay thread that adds one-way
// delay, random loss and a rate-limited bottleneck queue to the IPv4 packets moving between them.
// The kernel here has no netem/tc qdiscs, so the impairment is done in this process.
//
//   server namespace            relay thread (this process)           client namespace
//   10.77.0.1 (vctun0) <--> [loss -> bottleneck queue -> delay] <--> 10.77.0.2 (vctun0)
//
// Each namespace has its own loopback (up) and one TUN device (IFF_TUN | IFF_NO_PI, MTU 1500),
// configured with ioctls as a point-to-point /32 whose peer route points at the other side. The
// addresses exist only inside these namespaces, so no traffic leaves the machine, and several links
// (in one process or in parallel test processes) never collide.
//
// Needs: Linux, CAP_SYS_ADMIN (unshare(CLONE_NEWNET), setns) and CAP_NET_ADMIN (TUN, interface
// configuration) - in practice, running as root - and /dev/net/tun. Where the machine cannot host
// the link, create() returns nullptr and says why in `why_not`; tests then GTEST_SKIP() with that
// reason. Any other failure (a configuration ioctl that should not fail) throws volcast::Error.
//
// IPv4 only: IPv6 is disabled in both namespaces (no duplicate address detection, router
// solicitations or MLD reports on the link; best effort where /proc/sys is read-only), and the
// relay drops any non-IPv4 packet (DirectionCounters::dropped_not_ipv4). TSO/GSO do not apply: a
// TUN device opened without IFF_VNET_HDR offers no offloads, so the kernel segments before the
// relay and every packet it sees is at most the MTU (1500 bytes).
//
// Usage (sockets made inside a namespace stay there and may be used from any thread):
//   std::string why;
//   auto link = ImpairedLink::create({.one_way_delay_us = 20'000, .loss = 0.05}, &why);
//   if (!link) GTEST_SKIP() << why;
//   int listener = link->in_server_namespace([&] { return listen_on(link->server_address()); });
//   int client = link->in_client_namespace([&] { return connect_to(link->server_address()); });
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <type_traits>
#include <utility>
#include <vector>

namespace volcast {

/// The impairment of one direction of the link. Defaults: a perfect link.
struct LinkImpairment {
  /// Added to every packet in this direction, in microseconds. It is one-way: with the same
  /// value both ways, a round trip gains 2 * one_way_delay_us.
  int64_t one_way_delay_us = 0;
  /// Probability in [0, 1] that a packet is dropped, independently per packet, decided as the
  /// packet enters the link (before the queue, like netem).
  double loss = 0;
  /// Bottleneck rate in bits per second of IP packet bytes (no link-layer overhead); 0 = unlimited.
  double rate_bits_per_s = 0;
  /// Bytes the bottleneck may hold waiting to be sent (only with a rate); a packet that does not
  /// fit is dropped (tail drop). A packet reaching an idle bottleneck is always accepted.
  size_t queue_bytes = 256 * 1024;
  /// Seed of this direction's loss generator: the same seed and the same packet sequence drop the
  /// same packets. The two directions use different streams even with the same seed.
  uint64_t seed = 1;
};

/// Packet counts of one direction.
struct DirectionCounters {
  uint64_t packets_in = 0;         ///< IPv4 packets read from the sending side's TUN
  uint64_t bytes_in = 0;           ///< their bytes
  uint64_t packets_forwarded = 0;  ///< written to the receiving side's TUN
  uint64_t bytes_forwarded = 0;    ///< their bytes
  uint64_t dropped_loss = 0;       ///< dropped by random loss
  uint64_t dropped_queue = 0;      ///< tail-dropped at a full bottleneck queue
  uint64_t write_errors = 0;       ///< due, but the write to the receiving TUN failed
  uint64_t dropped_not_ipv4 = 0;   ///< not IPv4 (not in packets_in; draws no loss decision)
  /// packets_in = packets_forwarded + dropped_loss + dropped_queue + write_errors + still queued.
  uint64_t dropped() const {
    return dropped_loss + dropped_queue + write_errors + dropped_not_ipv4;
  }
};

struct LinkCounters {
  DirectionCounters server_to_client;
  DirectionCounters client_to_server;
};

/// One direction's impairment as a pure, clock-free queue (the relay drives it with
/// steady_clock times). Public so its timing can be unit-tested without namespaces or root.
/// Not thread-safe by itself.
class ImpairmentQueue {
 public:
  using Clock = std::chrono::steady_clock;
  enum class Verdict { kQueued, kLost, kQueueFull };

  /// `stream` selects an independent loss stream for the same seed (the relay uses 0 and 1).
  explicit ImpairmentQueue(const LinkImpairment& impairment, uint64_t stream = 0);
  /// Changes delay, loss, rate and queue size for packets that arrive from now on (packets already
  /// queued keep their times; packets still leave in order). The loss generator is not reseeded.
  void set_impairment(const LinkImpairment& impairment);
  const LinkImpairment& impairment() const { return impairment_; }

  /// Offers a packet that arrived at `arrival` (arrival times must not decrease).
  Verdict push(std::vector<uint8_t> packet, Clock::time_point arrival);
  /// When the oldest queued packet is due, or nullopt when empty.
  std::optional<Clock::time_point> next_release() const;
  /// Moves the oldest packet into `out` if it is due at `now`.
  bool pop_due(Clock::time_point now, std::vector<uint8_t>& out);
  size_t size() const { return queue_.size(); }
  /// Bytes waiting for the bottleneck at time `t` (0 without a rate limit).
  size_t backlog_bytes(Clock::time_point t) const;

 private:
  double next_uniform();  // [0, 1)

  struct Entry {
    Clock::time_point release;
    std::vector<uint8_t> packet;
  };
  LinkImpairment impairment_;
  uint64_t rng_state_;
  std::deque<Entry> queue_;
  Clock::time_point bottleneck_free_{};  // when the bottleneck finishes everything accepted
  Clock::time_point last_release_{};     // keeps packets in order when the delay shrinks
};

/// The link: two namespaces, two TUN devices and the relay thread. Not copyable or movable.
class ImpairedLink {
 public:
  /// The same impairment in both directions (each direction has its own queue and loss stream).
  static std::unique_ptr<ImpairedLink> create(const LinkImpairment& both_ways,
                                              std::string* why_not);
  /// Separate impairments: server -> client (downstream) and client -> server (upstream).
  /// Returns nullptr with the reason in `*why_not` (if not null) when the machine cannot host the
  /// link (no permission for unshare/setns, no /dev/net/tun); throws volcast::Error otherwise.
  static std::unique_ptr<ImpairedLink> create(const LinkImpairment& server_to_client,
                                              const LinkImpairment& client_to_server,
                                              std::string* why_not);
  /// Stops the relay, removes both TUN devices and releases both namespaces. Sockets still open in
  /// a namespace keep it alive, but their packets go nowhere.
  ~ImpairedLink();
  ImpairedLink(const ImpairedLink&) = delete;
  ImpairedLink& operator=(const ImpairedLink&) = delete;

  std::string server_address() const { return "10.77.0.1"; }
  std::string client_address() const { return "10.77.0.2"; }

  /// Runs `f` on the calling thread inside the server (client) namespace, via setns(), and returns
  /// its result; the thread's own namespace is restored afterwards, also when `f` throws. Only the
  /// calling thread moves. Throws volcast::Error naming the syscall and errno if setns fails. If
  /// restoring fails while `f` is throwing, the process is terminated rather than leave a thread
  /// in the wrong namespace.
  template <class F>
  std::invoke_result_t<F&> in_server_namespace(F&& f) const {
    return in_namespace(server_ns_fd_, "server", f);
  }
  template <class F>
  std::invoke_result_t<F&> in_client_namespace(F&& f) const {
    return in_namespace(client_ns_fd_, "client", f);
  }

  /// True when IPv6 is off in both namespaces (the usual case). False where /proc/sys could not be
  /// written (e.g. mounted read-only): then IPv6 link-local chatter (router solicitations, MLD)
  /// reaches the relay, which drops it (dropped_not_ipv4); IPv4 traffic is unaffected.
  bool ipv6_disabled() const { return ipv6_disabled_; }

  /// A snapshot of the per-direction counts.
  LinkCounters counters() const;
  /// Changes the impairments while the link runs (see ImpairmentQueue::set_impairment).
  void set_impairment(const LinkImpairment& server_to_client,
                      const LinkImpairment& client_to_server);

 private:
  ImpairedLink() = default;
  void relay();
  static void run_in_namespace(int ns_fd, const char* name, const std::function<void()>& f);
  template <class F>
  static std::invoke_result_t<F&> in_namespace(int ns_fd, const char* name, F& f) {
    using R = std::invoke_result_t<F&>;
    if constexpr (std::is_void_v<R>) {
      run_in_namespace(ns_fd, name, [&] { f(); });
    } else {
      std::optional<R> result;
      run_in_namespace(ns_fd, name, [&] { result.emplace(f()); });
      return std::move(*result);
    }
  }

  struct Direction {
    explicit Direction(const LinkImpairment& impairment, uint64_t stream)
        : queue(impairment, stream) {}
    ImpairmentQueue queue;
    DirectionCounters counters;
  };

  int server_ns_fd_ = -1;
  int client_ns_fd_ = -1;
  int server_tun_fd_ = -1;
  int client_tun_fd_ = -1;
  int stop_fd_ = -1;  // eventfd that wakes and stops the relay
  bool ipv6_disabled_ = false;
  mutable std::mutex mutex_;  // guards both directions
  std::unique_ptr<Direction> to_client_;
  std::unique_ptr<Direction> to_server_;
  std::thread relay_;
};

}  // namespace volcast
