#pragma once
// What a view just drew, as surfaces a pointer's ray meets (reconstruct/surface_hit.hpp): the
// window's mouse ray meets whatever is drawn under the mouse -- the live clouds, organs, the
// monitor, the room -- read back from the depth buffer of the target it was drawn into. OpenGL
// 4.5 core, on the thread whose context drew it, before the next frame clears it.
#include <optional>

#include "volcast/reconstruct/surface_hit.hpp"
#include "volcast/render/render_target.hpp"
#include "volcast/render/view.hpp"

namespace volcast {

class DrawnDepth final : public SurfaceHit {
 public:
  /// `view` drew into `target` (its framebuffer's depth is read; the viewport is target's).
  DrawnDepth(const View& view, const RenderTarget& target) : view_(view), target_(target) {}
  /// A ray from the view's eye (origin within 1 mm of view.world_from_view's translation; from
  /// anywhere else: nullopt, the depth buffer knows only the eye's rays): the point drawn at the
  /// pixel it passes through, nullopt where nothing was drawn (the far plane), or where the ray
  /// leaves the viewport or points away from the view. Room (world) frame, metres.
  std::optional<Eigen::Vector3f> hit(const Eigen::Vector3f& origin,
                                     const Eigen::Vector3f& direction) const override;

 private:
  View view_;
  RenderTarget target_;
};

}  // namespace volcast
