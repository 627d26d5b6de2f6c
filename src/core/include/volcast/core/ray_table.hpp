#pragma once
// Per-pixel ray table ("xy table" in the Azure Kinect SDK): for each pixel of an image, the
// normalised direction (X/Z, Y/Z) of the ray through its centre, lens distortion included.
// A point at depth z metres on pixel i is (x[i] * z, y[i] * z, z) in the camera frame.
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

}  // namespace volcast
