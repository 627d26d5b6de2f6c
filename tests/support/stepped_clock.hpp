#pragma once
// A site clock a test steps tick by tick (SiteOptions::now_us / sleep_until_us): the site's wait
// for a tick returns once the test has allowed it, and time then reads that tick's due time
// exactly. So a site's pacing is a matter of counts, whatever the machine's load. Synthetic
// timing: for exact behaviour only.
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>

#include "volcast/pipeline/sender.hpp"

namespace volcast::test {

class SteppedClock {
 public:
  /// Lets the site run `ticks` more ticks.
  void allow(int ticks) {
    {
      std::lock_guard lock(state_->m);
      state_->allowed += ticks;
    }
    state_->cv.notify_all();
  }
  /// Moves time on by `us` without a tick, as if the site had stalled that long (call it from
  /// the site's thread, e.g. in its publish callback).
  void advance(int64_t us) {
    std::lock_guard lock(state_->m);
    state_->now += us;
  }
  /// Lets the site run freely (in this clock's time), e.g. before SitePlayer::stop().
  void release() {
    {
      std::lock_guard lock(state_->m);
      state_->released = true;
    }
    state_->cv.notify_all();
  }
  /// Site options running on this clock (the clock's state is shared with them).
  SiteOptions options(SiteOptions o = {}) const {
    o.now_us = [s = state_] {
      std::lock_guard lock(s->m);
      return s->now;
    };
    o.sleep_until_us = [s = state_](int64_t t) {
      std::unique_lock lock(s->m);
      s->cv.wait(lock, [&] { return s->released || s->allowed > 0; });
      if (!s->released) --s->allowed;
      if (t > s->now) s->now = t;
    };
    return o;
  }

 private:
  struct State {
    std::mutex m;
    std::condition_variable cv;
    int64_t now = 0;  // µs
    int allowed = 0;
    bool released = false;
  };
  std::shared_ptr<State> state_ = std::make_shared<State>();
};

/// Releases `clock` when it goes out of scope: declared after the SitePlayer, so that a test that
/// returns early (a failed ASSERT) lets the site's thread go before the player's destructor joins
/// it, instead of hanging.
struct ReleaseOnExit {
  SteppedClock& clock;
  explicit ReleaseOnExit(SteppedClock& c) : clock(c) {}
  ReleaseOnExit(const ReleaseOnExit&) = delete;
  ReleaseOnExit& operator=(const ReleaseOnExit&) = delete;
  ~ReleaseOnExit() { clock.release(); }
};

}  // namespace volcast::test
