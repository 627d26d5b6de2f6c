#pragma once
// Keeping idle cores awake while streaming (Linux PM QoS, "CPU latency QoS" in the kernel's
// Documentation/power/pm_qos_interface.rst).
//
// Every frame set crosses several threads (site -> tier encoder and its workers -> viewer sender;
// receiver -> its decode workers), and a thread handed work on an idle core waits until that core
// wakes. On a virtual machine whose idle driver halts at once (cpuidle-haltpoll with
// guest_halt_poll_ns = 0, as on the 2-core CI machine) that wait was 1.7 ms at the median and the
// woken core runs its first tasks with cold caches: 4 cameras' decode tasks took 14.3 ms of CPU
// in the viewer against 7.6 ms in the one-thread benchmark. WorkerPool::prewake hides part of the
// wake-up; asking for 0 µs of wake-up latency makes idle cores poll instead of halting: p50
// 13.5 ms end to end instead of 14.6-15.1 (volcast demo --cameras 4 --no-render --seconds 20,
// with and without --low-latency).
// The price: idle cores spin (power, and a busy-looking machine) while the request is held.
#include <cstdint>
#include <string>

namespace volcast {

/// Holds a CPU wake-up latency request while alive: opens /dev/cpu_dma_latency, writes
/// `max_latency_us` (int32, microseconds; 0 = cores never sleep) and keeps the file open (the
/// kernel drops the request when it is closed). Never throws: where the device is missing or not
/// writable (it is root's, mode 0600, by default) active() is false and error() says why.
class CpuLatencyRequest {
 public:
  explicit CpuLatencyRequest(int32_t max_latency_us = 0);
  ~CpuLatencyRequest();
  CpuLatencyRequest(const CpuLatencyRequest&) = delete;
  CpuLatencyRequest& operator=(const CpuLatencyRequest&) = delete;

  bool active() const { return fd_ >= 0; }
  const std::string& error() const { return error_; }

 private:
  int fd_ = -1;
  std::string error_;
};

/// The system's current CPU latency limit in µs (the smallest request held by any process;
/// 2000000000 when none), read from /dev/cpu_dma_latency; -1 if it cannot be read.
int64_t current_cpu_latency_limit_us();

}  // namespace volcast
