#include "volcast/reconstruct/avatar_filter.hpp"

#include <Eigen/Geometry>
#include <algorithm>

namespace volcast {
namespace {

// The filter with the headset pose inverted once, for testing many points.
struct PreparedFilter {
  bool keep = false, hide = false;
  Eigen::Vector3f center;
  float radius2 = 0;
  Eigen::Matrix3f headset_from_world_rotation;
  Eigen::Vector3f headset_from_world_translation, half_extent;

  explicit PreparedFilter(const AvatarFilter& f) {
    if (f.keep) {
      keep = true;
      center = f.keep->center;
      radius2 = f.keep->radius_m * f.keep->radius_m;
    }
    if (f.hide) {
      hide = true;
      const RigidTransform headset_from_world = f.hide->world_from_headset.inverse();
      headset_from_world_rotation = headset_from_world.rotation.cast<float>();
      headset_from_world_translation = headset_from_world.translation.cast<float>();
      half_extent = f.hide->half_extent_m;
    }
  }
  bool keeps(const Eigen::Vector3f& p) const {
    if (keep && (p - center).squaredNorm() > radius2) return false;
    if (hide) {
      const Eigen::Vector3f h =
          (headset_from_world_rotation * p + headset_from_world_translation).cwiseAbs();
      if ((h.array() <= half_extent.array()).all()) return false;
    }
    return true;
  }
};

}  // namespace

bool avatar_filter_keeps(const AvatarFilter& filter, const Eigen::Vector3f& p_world) {
  return PreparedFilter(filter).keeps(p_world);
}

size_t apply_avatar_filter(const AvatarFilter& filter, PointCloud& cloud) {
  if (!filter.keep && !filter.hide) return 0;
  const PreparedFilter f(filter);
  auto& points = cloud.points;
  const auto end = std::remove_if(points.begin(), points.end(), [&](const SplatPoint& p) {
    return !f.keeps(Eigen::Vector3f(p.position[0], p.position[1], p.position[2]));
  });
  const size_t removed = static_cast<size_t>(points.end() - end);
  points.erase(end, points.end());
  return removed;
}

}  // namespace volcast
