#include "volcast/capture/registration.hpp"

#include <cmath>

#include "volcast/core/error.hpp"

namespace volcast {

ColorToDepthRegistration::ColorToDepthRegistration(const Intrinsics& depth, const Intrinsics& color,
                                                   const RigidTransform& color_from_depth)
    : depth_(depth),
      color_(color),
      color_from_depth_(color_from_depth),
      rays_(shared_ray_table(depth)) {}

void ColorToDepthRegistration::apply(const DepthImage& depth, const ColorImage& color,
                                     ColorImage& out) const {
  if (depth.width != depth_.width || depth.height != depth_.height)
    throw Error("registration: depth image size does not match the depth intrinsics");
  if (color.width != color_.width || color.height != color_.height)
    throw Error("registration: color image size does not match the color intrinsics");
  if (out.width != depth.width || out.height != depth.height)
    out = ColorImage(depth.width, depth.height);
  const Eigen::Matrix3d& r = color_from_depth_.rotation;
  const Eigen::Vector3d& t = color_from_depth_.translation;
  const int cw = color.width, ch = color.height;
  for (size_t i = 0; i < depth.size(); ++i) {
    uint8_t* dst = &out.bgra[i * 4];
    dst[0] = dst[1] = dst[2] = dst[3] = 0;
    const uint16_t d = depth.pixels[i];
    if (d == 0 || std::isnan(rays_->x[i])) continue;
    const double z = d * 0.001;
    const Eigen::Vector3d p = r * Eigen::Vector3d(rays_->x[i] * z, rays_->y[i] * z, z) + t;
    if (p.z() <= 0) continue;
    auto uv = project_normalized(color_, {p.x() / p.z(), p.y() / p.z()});
    if (!uv) continue;
    const double u = uv->x(), v = uv->y();
    if (!(u >= 0 && v >= 0 && u <= cw - 1 && v <= ch - 1)) continue;
    const int u0 = std::min(static_cast<int>(u), cw - 2),
              v0 = std::min(static_cast<int>(v), ch - 2);
    const double fu = u - u0, fv = v - v0;
    const uint8_t* c00 = color.pixel(u0, v0);
    const uint8_t* c10 = c00 + 4;
    const uint8_t* c01 = color.pixel(u0, v0 + 1);
    const uint8_t* c11 = c01 + 4;
    for (int c = 0; c < 3; ++c) {
      const double top = c00[c] + (c10[c] - c00[c]) * fu;
      const double bottom = c01[c] + (c11[c] - c01[c]) * fu;
      dst[c] = static_cast<uint8_t>(top + (bottom - top) * fv + 0.5);
    }
    dst[3] = 255;
  }
}

}  // namespace volcast
