#pragma once
// Per-pixel ray table ("xy table" in the Azure Kinect SDK): for each pixel of an image, the
// normalised direction (X/Z, Y/Z) of the ray through its centre, lens distortion included.
// A point at depth z metres on pixel i is (x[i] * z, y[i] * z, z) in the camera frame.
#include <memory>
#include <vector>

#include "volcast/core/calibration.hpp"

namespace volcast {

struct RayTable {
  int width = 0;
  int height = 0;
  std::vector<float> x;  ///< X/Z per pixel, row-major; NaN where the lens model has no ray
  std::vector<float> y;  ///< Y/Z per pixel, row-major; NaN where the lens model has no ray
};

/// Builds the table by unprojecting every pixel centre with unproject_pixel. O(width*height)
/// Newton solves: build once per camera, not per frame.
RayTable make_ray_table(const Intrinsics& intrinsics);

/// make_ray_table(intrinsics), made once in this process and shared while the newest 16 distinct
/// intrinsics asked for are kept: the renderers of several participants or windows in one process
/// (the demo's, a test's) see the same site cameras, and an Azure Kinect's table is 368,640
/// Newton solves. Thread-safe; a caller asking for a table another thread is making waits for it.
std::shared_ptr<const RayTable> shared_ray_table(const Intrinsics& intrinsics);

}  // namespace volcast
