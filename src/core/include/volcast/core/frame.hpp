#pragma once
// A frame set: one capture of every camera of a site.
#include <cstdint>
#include <vector>

#include "volcast/core/image.hpp"

namespace volcast {

/// One camera's capture: depth (mm) and color registered to the depth pixel grid (same size),
/// or an empty color image if the camera has none.
struct CameraFrame {
  DepthImage depth;
  ColorImage color;
  int64_t device_timestamp_us = 0;  ///< the camera's own clock (recording timestamp), microseconds
};

/// One capture of every camera of a site, in camera order. capture_time_us is the server's wall
/// clock (microseconds since the Unix epoch) when the set was captured/read.
struct FrameSet {
  uint64_t sequence = 0;
  int64_t capture_time_us = 0;
  std::vector<CameraFrame> cameras;
};

}  // namespace volcast
