#pragma once
// Color-to-depth registration, as the Azure Kinect SDK's
// k4a_transformation_color_image_to_depth_camera: every valid depth pixel is unprojected with the
// depth ray table, moved into the color camera with color_from_depth, projected with the color
// intrinsics, and takes the color found there (bilinear). Pixels without depth or outside the color
// image get BGRA (0, 0, 0, 0).
#include "volcast/core/calibration.hpp"
#include "volcast/core/image.hpp"
#include "volcast/core/ray_table.hpp"

namespace volcast {

class ColorToDepthRegistration {
 public:
  ColorToDepthRegistration(const Intrinsics& depth, const Intrinsics& color,
                           const RigidTransform& color_from_depth);
  /// `depth` must match the depth intrinsics' size and `color` the color intrinsics' size.
  /// `out` is resized to the depth size and reused (no allocation once sized).
  void apply(const DepthImage& depth, const ColorImage& color, ColorImage& out) const;

 private:
  Intrinsics depth_, color_;
  RigidTransform color_from_depth_;
  std::shared_ptr<const RayTable> rays_;  // shared_ray_table: one per intrinsics per process
};

}  // namespace volcast
