#pragma once
// A TCP proxy on 127.0.0.1 for tests of a cut path, without root or network namespaces: it
// forwards every connection to `target_port`, until cut() -- then the connections open at that
// moment stop moving for good (nothing read or written either way, the sockets kept open: to both
// ends it looks like a path that went silent, as a cut does before any timeout), and new ones are
// closed as soon as they come, until restore() (the path came back): from then on new connections
// are forwarded as before. One thread polls everything.
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <cstdint>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <vector>

namespace volcast::test {

class StallingProxy {
 public:
  explicit StallingProxy(uint16_t target_port) : target_port_(target_port) {
    listener_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    const int one = 1;
    ::setsockopt(listener_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    sockaddr_in a = loopback(0);
    if (::bind(listener_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 ||
        ::listen(listener_, 16) != 0)
      throw std::runtime_error("proxy: cannot listen");
    socklen_t n = sizeof a;
    ::getsockname(listener_, reinterpret_cast<sockaddr*>(&a), &n);
    port_ = ntohs(a.sin_port);
    thread_ = std::thread([this] { run(); });
  }
  ~StallingProxy() {
    stop_ = true;
    thread_.join();
    for (const Pair& p : pairs_) {
      ::close(p.a);
      ::close(p.b);
    }
    ::close(listener_);
  }
  uint16_t port() const { return port_; }
  /// The connections open now stop moving, for good; new ones are closed until restore().
  void cut() {
    std::lock_guard lock(mutex_);
    for (Pair& p : pairs_) p.stalled = true;
    down_ = true;
  }
  /// New connections are forwarded again.
  void restore() { down_ = false; }
  /// Connections forwarded so far.
  int accepted() const { return accepted_; }

 private:
  struct Pair {
    int a = -1, b = -1;  // the client's side, the target's side
    bool stalled = false;
  };
  static sockaddr_in loopback(uint16_t port) {
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = htons(port);
    return a;
  }
  // Moves what `from` has to `to` (blocking write: both are loopback). False when `from` ended.
  static bool pump(int from, int to) {
    char buffer[65536];
    const ssize_t n = ::read(from, buffer, sizeof buffer);
    if (n <= 0) return false;
    for (ssize_t done = 0; done < n;) {
      const ssize_t w = ::write(to, buffer + done, static_cast<size_t>(n - done));
      if (w <= 0) return false;
      done += w;
    }
    return true;
  }
  void run() {
    while (!stop_) {
      std::vector<pollfd> fds{{listener_, POLLIN, 0}};
      std::vector<size_t> owner{SIZE_MAX};
      {
        std::lock_guard lock(mutex_);
        for (size_t i = 0; i < pairs_.size(); ++i) {
          if (pairs_[i].stalled || pairs_[i].a < 0) continue;
          fds.push_back({pairs_[i].a, POLLIN, 0});
          owner.push_back(i);
          fds.push_back({pairs_[i].b, POLLIN, 0});
          owner.push_back(i);
        }
      }
      if (::poll(fds.data(), fds.size(), 50) <= 0) continue;
      if (fds[0].revents & POLLIN) accept_one();
      std::lock_guard lock(mutex_);
      for (size_t k = 1; k < fds.size(); ++k) {
        Pair& p = pairs_[owner[k]];
        if (!(fds[k].revents & (POLLIN | POLLHUP | POLLERR)) || p.stalled || p.a < 0) continue;
        const bool ok = fds[k].fd == p.a ? pump(p.a, p.b) : pump(p.b, p.a);
        if (!ok) {  // one side ended: so does the other
          ::close(p.a);
          ::close(p.b);
          p.a = p.b = -1;
        }
      }
    }
  }
  void accept_one() {
    const int client = ::accept4(listener_, nullptr, nullptr, SOCK_CLOEXEC);
    if (client < 0) return;
    if (down_) {  // the path is down: the connection goes nowhere
      ::close(client);
      return;
    }
    const int target = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in a = loopback(target_port_);
    if (::connect(target, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
      ::close(client);
      ::close(target);
      return;
    }
    const int one = 1;
    for (int fd : {client, target}) ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    std::lock_guard lock(mutex_);
    pairs_.push_back({client, target, false});
    ++accepted_;
  }

  uint16_t target_port_;
  int listener_ = -1;
  uint16_t port_ = 0;
  std::mutex mutex_;
  std::vector<Pair> pairs_;
  std::atomic<int> accepted_{0};
  std::atomic<bool> stop_{false}, down_{false};
  std::thread thread_;
};

}  // namespace volcast::test
