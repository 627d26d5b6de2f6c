#include "volcast/core/clock.hpp"

#include <chrono>

namespace volcast {

int64_t wall_clock_us() {
  using namespace std::chrono;
  return duration_cast<microseconds>(system_clock::now().time_since_epoch()).count();
}

}  // namespace volcast
