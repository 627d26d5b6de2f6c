#include "volcast/core/worker_pool.hpp"

#include <algorithm>

namespace volcast {

WorkerPool::WorkerPool(int threads) {
  if (threads <= 0)
    threads = std::max(1, static_cast<int>(std::thread::hardware_concurrency()) - 1);
  for (int i = 0; i < threads; ++i) workers_.emplace_back([this] { work(); });
}

WorkerPool::~WorkerPool() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
    posted_.fetch_add(1, std::memory_order_release);  // ends any prewake polling
  }
  wake_.notify_all();
  for (auto& t : workers_) t.join();
}

bool WorkerPool::run_one() {
  size_t i;
  const std::function<void(size_t)>* fn;
  {
    std::lock_guard lock(mutex_);
    if (!fn_ || next_ >= n_) return false;
    i = next_++;
    fn = fn_;
  }
  std::exception_ptr error;
  try {
    (*fn)(i);
  } catch (...) {
    error = std::current_exception();
  }
  std::lock_guard lock(mutex_);
  if (error && !error_) error_ = error;
  if (++finished_ == n_) done_.notify_all();
  return true;
}

void WorkerPool::work() {
  uint64_t seen = 0, seen_prewakes = 0;
  while (true) {
    std::chrono::steady_clock::time_point spin_until;
    {
      std::unique_lock lock(mutex_);
      const auto job = [&] { return generation_ != seen && fn_ && next_ < n_; };
      wake_.wait(lock, [&] { return stop_ || job() || prewakes_ != seen_prewakes; });
      if (stop_) return;
      if (!job()) {  // woken ahead of a job: poll for it until spin_until, then sleep again
        seen_prewakes = prewakes_;
        spin_until = spin_until_;
      } else {
        seen = generation_;
      }
    }
    if (spin_until != std::chrono::steady_clock::time_point{}) {
      while (posted_.load(std::memory_order_acquire) == seen &&
             std::chrono::steady_clock::now() < spin_until)
        std::this_thread::yield();
      continue;  // a job posted meanwhile is taken up by the wait above
    }
    while (run_one()) {
    }
  }
}

void WorkerPool::prewake(std::chrono::microseconds spin) {
  if (workers_.empty()) return;
  {
    std::lock_guard lock(mutex_);
    ++prewakes_;
    spin_until_ = std::chrono::steady_clock::now() + spin;
  }
  wake_.notify_all();
}

void WorkerPool::parallel_for(size_t n, const std::function<void(size_t)>& fn) {
  if (n == 0) return;
  if (n == 1 || workers_.empty()) {
    for (size_t i = 0; i < n; ++i) fn(i);
    return;
  }
  std::lock_guard call(call_mutex_);
  {
    std::lock_guard lock(mutex_);
    fn_ = &fn;
    n_ = n;
    next_ = finished_ = 0;
    error_ = nullptr;
    ++generation_;
    posted_.store(generation_, std::memory_order_release);
  }
  wake_.notify_all();
  while (run_one()) {
  }
  std::exception_ptr error;
  {
    std::unique_lock lock(mutex_);
    done_.wait(lock, [&] { return finished_ == n_; });
    fn_ = nullptr;
    error = error_;
  }
  if (error) std::rethrow_exception(error);
}

}  // namespace volcast
