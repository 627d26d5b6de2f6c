#include "volcast/core/cpu_latency.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace volcast {
namespace {
constexpr const char* kDevice = "/dev/cpu_dma_latency";
}  // namespace

CpuLatencyRequest::CpuLatencyRequest(int32_t max_latency_us) {
  if (max_latency_us < 0) {
    error_ = "a CPU latency request must be >= 0 us";
    return;
  }
  const int fd = ::open(kDevice, O_WRONLY | O_CLOEXEC);
  if (fd < 0) {
    error_ = std::string("cannot open ") + kDevice + ": " + std::strerror(errno);
    return;
  }
  if (::write(fd, &max_latency_us, sizeof max_latency_us) != sizeof max_latency_us) {
    error_ = std::string("cannot write ") + kDevice + ": " + std::strerror(errno);
    ::close(fd);
    return;
  }
  fd_ = fd;
}

CpuLatencyRequest::~CpuLatencyRequest() {
  if (fd_ >= 0) ::close(fd_);  // the kernel drops the request
}

int64_t current_cpu_latency_limit_us() {
  const int fd = ::open(kDevice, O_RDONLY | O_CLOEXEC);
  if (fd < 0) return -1;
  int32_t value = 0;
  const ssize_t n = ::pread(fd, &value, sizeof value, 0);
  ::close(fd);
  return n == sizeof value ? value : -1;
}

}  // namespace volcast
