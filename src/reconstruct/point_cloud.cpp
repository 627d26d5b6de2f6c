#include "volcast/reconstruct/point_cloud.hpp"

#include <cmath>

#include "volcast/core/error.hpp"

namespace volcast {

CloudBuilder::CloudBuilder(const CameraCalibration& calibration)
    : calibration_(calibration),
      rays_(make_ray_table(calibration.depth)),
      rotation_(calibration.world_from_camera.rotation.cast<float>()),
      translation_(calibration.world_from_camera.translation.cast<float>()),
      radius_per_metre_(splat_radius_per_metre(calibration.depth)) {}

void CloudBuilder::build(const DepthImage& depth, const ColorImage& color, PointCloud& out) const {
  const Intrinsics& k = calibration_.depth;
  if (depth.width != k.width || depth.height != k.height)
    throw Error("point cloud: depth size differs from the camera's calibration");
  const bool has_color = !color.empty();
  if (has_color && (color.width != depth.width || color.height != depth.height))
    throw Error("point cloud: color is not registered to depth (size differs)");
  out.points.clear();
  out.points.reserve(depth.size());
  constexpr uint32_t kNoColor = 0xff'a0'a0'a0u;
  for (size_t i = 0; i < depth.size(); ++i) {
    const uint16_t d = depth.pixels[i];
    const float rx = rays_.x[i];
    if (d == 0 || std::isnan(rx)) continue;
    const float z = static_cast<float>(d) * 0.001f;
    const Eigen::Vector3f p = rotation_ * Eigen::Vector3f(rx * z, rays_.y[i] * z, z) + translation_;
    uint32_t rgba = kNoColor;
    if (has_color) {
      const uint8_t* c = &color.bgra[i * 4];
      if (c[3] != 0)
        rgba = uint32_t{c[2]} | uint32_t{c[1]} << 8 | uint32_t{c[0]} << 16 | 0xff000000u;
    }
    out.points.push_back({{p.x(), p.y(), p.z()}, z * radius_per_metre_, rgba});
  }
}

}  // namespace volcast
