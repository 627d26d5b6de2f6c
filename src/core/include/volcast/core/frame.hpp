#pragma once
// Frame sets: one capture of every camera of a site.
#include <cstdint>
#include <memory>
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

/// One capture of every camera of a site, in camera order, as a receiver holds it after decoding
/// (buffers it owns and reuses). capture_time_us is the server's wall clock (microseconds since
/// the Unix epoch) when the set was captured/read.
struct FrameSet {
  uint64_t sequence = 0;
  int64_t capture_time_us = 0;
  std::vector<CameraFrame> cameras;
};

/// What a site publishes: one capture of every camera, in camera order, with the cameras' frames
/// shared and immutable. A frame repeated in several sets (a camera slower than the site) and every
/// tier's encoder read the same pixels; nothing is copied on the way out.
/// Times are the sender's wall clock, microseconds since the Unix epoch.
struct CapturedFrameSet {
  uint64_t sequence = 0;        ///< 1, 2, ... per site, without gaps
  int64_t capture_time_us = 0;  ///< when the frames were read from their sources
  int64_t filter_done_us = 0;   ///< when every camera's filter chain had run
  std::vector<std::shared_ptr<const CameraFrame>> cameras;
};

}  // namespace volcast
