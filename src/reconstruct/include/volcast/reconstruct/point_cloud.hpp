#pragma once
// Point clouds from depth + registered color, in the site's world frame.
#include <cstdint>
#include <vector>

#include "volcast/core/calibration.hpp"
#include "volcast/core/frame.hpp"
#include "volcast/core/ray_table.hpp"

namespace volcast {

/// One point, laid out for upload to the GPU as is (20 bytes).
struct SplatPoint {
  float position[3];  ///< world frame, metres
  float radius;   ///< splat radius in metres: 0.75 x the pixel's footprint (depth / focal length)
  uint32_t rgba;  ///< color, R in the lowest byte; gray (160) where the pixel had no color
};

struct PointCloud {
  std::vector<SplatPoint> points;
};

/// The splat radius per metre of depth: 0.75 x the pixel footprint, 0.75 * 2 / (fx + fy). The
/// GPU reconstruction (SplatRenderer::draw_cameras) uses the same figure.
inline float splat_radius_per_metre(const Intrinsics& k) {
  return static_cast<float>(0.75 * 2.0 / (k.fx + k.fy));
}

/// Turns one camera's depth images into world-space point clouds. Builds the camera's per-pixel
/// ray table (lens distortion included) once; build() allocates nothing once `out` has grown.
class CloudBuilder {
 public:
  explicit CloudBuilder(const CameraCalibration& calibration);
  /// depth: mm, the calibration's size. color: BGRA of the same size, or empty. Pixels with depth 0
  /// or no ray are skipped. Throws Error if the sizes do not match the calibration.
  void build(const DepthImage& depth, const ColorImage& color, PointCloud& out) const;

 private:
  CameraCalibration calibration_;
  RayTable rays_;
  Eigen::Matrix3f rotation_;
  Eigen::Vector3f translation_;
  float radius_per_metre_;
};

}  // namespace volcast
