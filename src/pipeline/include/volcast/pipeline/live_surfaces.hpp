#pragma once
// The OR site's surfaces as a participant sees them now: the newest depth frame of each site
// camera placed in the room (room_from_site * site_from_camera), for finding where a laser
// pointer's ray meets the live point clouds (reconstruct/ray_hit.hpp) -- against what the cameras
// measured, not a guess. The render thread updates it with each new frame; a pose script's thread
// (ScriptedPointing) asks it. One of the two SurfaceHits (reconstruct/surface_hit.hpp).
// Thread-safe.
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <vector>

#include "volcast/core/calibration.hpp"
#include "volcast/core/frame.hpp"
#include "volcast/reconstruct/surface_hit.hpp"

namespace volcast {

class LiveSurfaces final : public SurfaceHit {
 public:
  /// The site's cameras (site frame, as the Welcome gave them), their newest frames (null: none
  /// yet) and where the site sits in the room. Keeps the frames (shared), copies nothing else.
  void update(std::span<const CameraCalibration> site,
              std::span<const std::shared_ptr<const CameraFrame>> frames,
              const RigidTransform& room_from_site);
  /// How far a ray reaches (metres): further than across an operating room.
  static constexpr float kReachM = 8;
  /// Where the ray origin + t * direction (room frame, metres; any length) first meets a site
  /// camera's measured surface, within kReachM of `origin`, the nearest over the cameras; nullopt
  /// if it meets none or no frame has come yet.
  std::optional<Eigen::Vector3f> hit(const Eigen::Vector3f& origin,
                                     const Eigen::Vector3f& direction) const override;
  /// Whether a frame of any camera has come.
  bool ready() const override;

 private:
  mutable std::mutex mutex_;
  std::vector<CameraCalibration> cameras_;  // room frame
  std::vector<std::shared_ptr<const CameraFrame>> frames_;
};

}  // namespace volcast
