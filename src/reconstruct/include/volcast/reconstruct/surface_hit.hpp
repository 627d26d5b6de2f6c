#pragma once
// Where a pointing ray first meets what a participant sees: the one question every pointer asks
// (a laser pointer's dot, a stroke's points, a pinned label), answered two ways behind this
// interface --
//   * LiveSurfaces (pipeline/live_surfaces.hpp): marched against the site cameras' newest depth
//     images (ray_hit.hpp), for a headset's controller ray and a pose script's hand;
//   * DrawnDepth (render/drawn_depth.hpp): read from the depth buffer a view just drew, for the
//     window's mouse ray (what is under the mouse: clouds, organs, the monitor, the room).
// Room frame, metres.
#include <Eigen/Core>
#include <optional>

namespace volcast {

class SurfaceHit {
 public:
  virtual ~SurfaceHit() = default;
  /// The first point of the ray origin + t * direction (t >= 0; `direction` any non-zero length)
  /// on a surface, or nullopt if it meets none (or there is nothing to meet yet).
  virtual std::optional<Eigen::Vector3f> hit(const Eigen::Vector3f& origin,
                                             const Eigen::Vector3f& direction) const = 0;
  /// Whether there is anything to meet yet (a pose script waits for it before it points).
  virtual bool ready() const { return true; }
};

}  // namespace volcast
