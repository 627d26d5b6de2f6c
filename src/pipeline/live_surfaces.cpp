#include "volcast/pipeline/live_surfaces.hpp"

#include "volcast/reconstruct/ray_hit.hpp"

namespace volcast {

void LiveSurfaces::update(std::span<const CameraCalibration> site,
                          std::span<const std::shared_ptr<const CameraFrame>> frames,
                          const RigidTransform& room_from_site) {
  std::lock_guard lock(mutex_);
  cameras_.resize(site.size());
  frames_.resize(site.size());
  for (size_t i = 0; i < site.size(); ++i) {
    cameras_[i] = site[i];
    cameras_[i].world_from_camera = room_from_site * site[i].world_from_camera;
    if (i < frames.size() && frames[i]) frames_[i] = frames[i];
  }
}

bool LiveSurfaces::ready() const {
  std::lock_guard lock(mutex_);
  for (const auto& f : frames_)
    if (f) return true;
  return false;
}

std::optional<Eigen::Vector3f> LiveSurfaces::hit(const Eigen::Vector3f& origin,
                                                 const Eigen::Vector3f& direction) const {
  std::vector<CameraCalibration> cameras;
  std::vector<std::shared_ptr<const CameraFrame>> frames;
  {
    std::lock_guard lock(mutex_);
    cameras = cameras_;
    frames = frames_;
  }
  std::vector<const DepthImage*> depths;
  for (size_t i = 0; i < frames.size(); ++i) {
    const bool usable = frames[i] && frames[i]->depth.width == cameras[i].depth.width &&
                        frames[i]->depth.height == cameras[i].depth.height;
    depths.push_back(usable ? &frames[i]->depth : nullptr);
  }
  const auto h = hit_depths(cameras, depths, origin, direction, kReachM);
  if (!h) return std::nullopt;
  return h->point_world;
}

}  // namespace volcast
