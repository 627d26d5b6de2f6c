#pragma once
#include <cstdint>

namespace volcast {

/// Wall-clock time in microseconds since the Unix epoch (CLOCK_REALTIME). Server and viewer on one
/// host share it, so a capture timestamp and a viewer's arrival time give end-to-end latency.
int64_t wall_clock_us();

}  // namespace volcast
