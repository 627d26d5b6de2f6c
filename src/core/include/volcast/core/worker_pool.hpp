#pragma once
// A small fixed pool of worker threads for data-parallel work in the pipeline's hot path (the
// cameras of one frame set encoded or decoded at once). No allocation per call.
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace volcast {

class WorkerPool {
 public:
  /// `threads` workers besides the caller (0 = hardware threads - 1; so a 2-core machine gets 1).
  explicit WorkerPool(int threads = 0);
  ~WorkerPool();
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  /// Calls fn(i) for every i in [0, n), spread over the workers and the calling thread, and
  /// returns when all have finished. If calls throw, the first exception is rethrown here after all
  /// have finished. One parallel_for at a time per pool (calls from several threads take turns).
  /// `fn` must not call parallel_for on the same pool.
  void parallel_for(size_t n, const std::function<void(size_t)>& fn);
  int threads() const { return static_cast<int>(workers_.size()); }
  /// Wakes the workers ahead of a parallel_for expected within `spin`: until it comes (or `spin`
  /// has passed) they poll for it, yielding, instead of sleeping, so the job does not first wait
  /// for a sleeping core to wake (1-2 ms on a virtual machine whose idle cores halt). Costs up to
  /// `spin` of each worker's core; no effect on a job already running.
  void prewake(std::chrono::microseconds spin);

 private:
  void work();
  bool run_one();          // claims and runs one index of the current job; false if none is left
  std::mutex call_mutex_;  // one parallel_for at a time
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  const std::function<void(size_t)>* fn_ = nullptr;
  size_t n_ = 0, next_ = 0, finished_ = 0;
  uint64_t generation_ = 0;
  std::atomic<uint64_t> posted_{0};  // generation_, readable without the mutex
  uint64_t prewakes_ = 0;
  std::chrono::steady_clock::time_point spin_until_;
  std::exception_ptr error_;
  bool stop_ = false;
  std::vector<std::thread> workers_;
};

}  // namespace volcast
