#pragma once
// Internal to volcast_net_stream: how a viewer's thread is woken (server_impl.hpp).
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/timerfd.h>
#include <unistd.h>

#include <cstdint>

namespace volcast::detail {

// Wakes one viewer's thread, which polls `fd` (an epoll set of the two below): signal() at once
// (its tier has a new frame set, a session message is to be sent; an eventfd), at() when its held
// voice packets fall due (a timerfd: no wake-up before then). Each fd is created here; a failure
// leaves it -1, and poll(2) then reports the set as never ready.
struct WakeFd {
  int event = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  int timer = ::timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC);
  int fd = watch(event, timer);
  WakeFd() = default;
  WakeFd(const WakeFd&) = delete;
  WakeFd& operator=(const WakeFd&) = delete;
  ~WakeFd() {
    ::close(fd);
    ::close(timer);
    ::close(event);
  }
  void signal() const {
    const uint64_t one = 1;
    [[maybe_unused]] const auto n = ::write(event, &one, sizeof one);
  }
  // Wakes the thread once the steady clock (CLOCK_MONOTONIC, µs) reaches `due_us`; -1 disarms it.
  void at(int64_t due_us) const {
    itimerspec t{};
    if (due_us >= 0) {
      t.it_value.tv_sec = due_us / 1'000'000;
      t.it_value.tv_nsec = due_us % 1'000'000 * 1000 + 1;  // never all zero (that disarms)
    }
    ::timerfd_settime(timer, TFD_TIMER_ABSTIME, &t, nullptr);
  }
  void drain() const {
    uint64_t v;
    [[maybe_unused]] const auto a = ::read(event, &v, sizeof v);
    [[maybe_unused]] const auto b = ::read(timer, &v, sizeof v);
  }
  static int watch(int event, int timer) {
    const int set = ::epoll_create1(EPOLL_CLOEXEC);
    for (const int f : {event, timer}) {
      epoll_event e{};
      e.events = EPOLLIN;
      e.data.fd = f;
      ::epoll_ctl(set, EPOLL_CTL_ADD, f, &e);
    }
    return set;
  }
};

}  // namespace volcast::detail
