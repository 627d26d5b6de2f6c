// What a view just drew, as surfaces a pointer's ray meets (drawn_depth.hpp).
#include "volcast/render/drawn_depth.hpp"

#include <epoxy/gl.h>

#include <cmath>

namespace volcast {

std::optional<Eigen::Vector3f> DrawnDepth::hit(const Eigen::Vector3f& origin,
                                               const Eigen::Vector3f& direction) const {
  const Eigen::Vector3f eye = view_.world_from_view.translation.cast<float>();
  if ((origin - eye).norm() > 1e-3f || direction.squaredNorm() == 0) return std::nullopt;
  const Eigen::Matrix4f clip_from_world = view_.clip_from_world();
  const Eigen::Vector4f clip = clip_from_world * (eye + direction.normalized()).homogeneous();
  if (clip.w() <= 0) return std::nullopt;  // the ray points away from the view
  // The pixel it passes through, from the viewport's top left.
  const double x = (double(clip.x()) / clip.w() + 1) / 2 * target_.width;
  const double y = (1 - double(clip.y()) / clip.w()) / 2 * target_.height;
  if (!(x >= 0 && y >= 0 && x < target_.width && y < target_.height)) return std::nullopt;
  const int px = static_cast<int>(x), py = static_cast<int>(y);
  float depth = 1;
  glBindFramebuffer(GL_READ_FRAMEBUFFER, target_.framebuffer);
  glReadPixels(target_.x + px, target_.y + target_.height - 1 - py, 1, 1, GL_DEPTH_COMPONENT,
               GL_FLOAT, &depth);
  if (depth >= 1.0f) return std::nullopt;  // the far plane: nothing drawn there
  const Eigen::Vector4f ndc(float(2 * (px + 0.5) / target_.width - 1),
                            float(1 - 2 * (py + 0.5) / target_.height), 2 * depth - 1, 1);
  const Eigen::Vector4f p = clip_from_world.inverse() * ndc;
  return Eigen::Vector3f(p.head<3>() / p.w());
}

}  // namespace volcast
