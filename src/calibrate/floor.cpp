#include "volcast/calibrate/floor.hpp"

#include <open3d/geometry/PointCloud.h>
#include <open3d/utility/Logging.h>
#include <open3d/utility/Random.h>
#include <spdlog/fmt/fmt.h>

#include <Eigen/Geometry>
#include <cmath>

#include "volcast/core/error.hpp"

namespace volcast {

std::optional<FloorPlane> find_floor(std::span<const std::vector<Eigen::Vector3d>> clouds,
                                     std::span<const RigidTransform> world_from_camera,
                                     const std::optional<Eigen::Vector3d>& gravity_up,
                                     std::string& why_not) {
  if (clouds.size() != world_from_camera.size() || clouds.empty())
    throw Error("find_floor: needs one pose per cloud and at least one camera");
  open3d::utility::SetVerbosityLevel(open3d::utility::VerbosityLevel::Error);
  open3d::utility::random::Seed(11);
  open3d::geometry::PointCloud all;
  for (size_t c = 0; c < clouds.size(); ++c) {
    open3d::geometry::PointCloud one(clouds[c]);
    one.Transform([&] {
      Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
      m.topLeftCorner<3, 3>() = world_from_camera[c].rotation;
      m.topRightCorner<3, 1>() = world_from_camera[c].translation;
      return m;
    }());
    all += *one.VoxelDownSample(0.03);
  }
  const size_t total = all.points_.size();
  if (total < 500) {
    why_not = "too few depth samples (" + std::to_string(total) + ") to find a floor";
    return std::nullopt;
  }
  std::optional<FloorPlane> best;
  double best_score = -1e9;
  std::string seen;
  std::vector<std::pair<Eigen::Vector3d, double>> planes;  // every large plane: normal, share
  auto rest = std::make_shared<open3d::geometry::PointCloud>(all);
  for (int k = 0; k < 6 && rest->points_.size() > total / 20; ++k) {
    const auto [plane, inliers] = rest->SegmentPlane(0.02, 3, 2000);
    if (inliers.size() < total / 20) break;  // the rest holds no large plane
    Eigen::Vector3d n = plane.head<3>();
    double d = plane(3);
    const double norm = n.norm();
    n /= norm;
    d /= norm;
    // Face the cameras' side: their middle must lie above the plane.
    Eigen::Vector3d middle = Eigen::Vector3d::Zero();
    for (const auto& t : world_from_camera) middle += t.translation;
    middle /= static_cast<double>(world_from_camera.size());
    if (n.dot(middle) + d < 0) {
      n = -n;
      d = -d;
    }
    double lowest = 1e9, highest = -1e9, look_down = 1e9;
    for (const auto& t : world_from_camera) {
      const double h = n.dot(t.translation) + d;
      lowest = std::min(lowest, h);
      highest = std::max(highest, h);
      look_down = std::min(look_down, -n.dot(t.rotation.col(2)));  // optical axis toward it
    }
    double sum2 = 0;
    for (size_t i : inliers) sum2 += std::pow(n.dot(rest->points_[i]) + d, 2);
    const double share = static_cast<double>(inliers.size()) / static_cast<double>(total);
    planes.emplace_back(n, share);
    seen += fmt::format("{}plane {} ({:.0f}% of samples, cameras {:.2f}..{:.2f} m above it)",
                        seen.empty() ? "" : "; ", k + 1, share * 100, lowest, highest);
    const bool above = lowest > 0.2 && highest < 4.0;
    double score = -1e9;
    std::string reason;
    if (gravity_up) {
      const double angle = std::acos(std::clamp(n.dot(gravity_up->normalized()), -1.0, 1.0));
      if (above && angle < 15 * M_PI / 180) {
        score = share;
        reason = fmt::format("the largest plane within 15 deg of gravity ({:.1f} deg off)",
                             angle * 180 / M_PI);
      }
    } else if (above && look_down > -0.05) {
      score = look_down + 0.5 * share;
      double flattest = 1e9;
      for (const auto& t : world_from_camera)
        flattest = std::min(flattest, std::asin(std::clamp(-n.dot(t.rotation.col(2)), -1.0, 1.0)));
      double steepest = -1e9;
      for (const auto& t : world_from_camera)
        steepest = std::max(steepest, std::asin(std::clamp(-n.dot(t.rotation.col(2)), -1.0, 1.0)));
      reason = fmt::format(
          "the large plane every camera looks down at ({:.0f} to {:.0f} deg below the horizon); "
          "no gravity measurement",
          flattest * 180 / M_PI, steepest * 180 / M_PI);
    }
    if (score > best_score) {
      best_score = score;
      FloorPlane f;
      f.up = n;
      f.offset_m = d;
      f.inliers = static_cast<int>(inliers.size());
      f.rms_m = std::sqrt(sum2 / static_cast<double>(inliers.size()));
      f.share = share;
      f.reason = reason;
      best = f;
    }
    rest = rest->SelectByIndex(inliers, true);
  }
  if (!best || best_score <= -1e8) {
    why_not = "no plane qualifies as the floor (" + (seen.empty() ? "no large plane" : seen) +
              (gravity_up ? "; none within 15 deg of gravity with every camera 0.2 to 4 m above it)"
                          : "; none that every camera looks down at from 0.2 to 4 m above it)");
    return std::nullopt;
  }
  // The largest wall (a plane within 10 degrees of vertical) gives the room its axes.
  double wall_share = 0;
  for (const auto& [normal, share] : planes)
    if (std::abs(normal.dot(best->up)) < std::sin(10 * M_PI / 180) && share > wall_share) {
      wall_share = share;
      best->wall = normal;
    }
  return best;
}

RigidTransform room_from_site(const FloorPlane& floor,
                              std::span<const RigidTransform> world_from_camera) {
  if (world_from_camera.empty()) throw Error("room_from_site: no cameras");
  const Eigen::Vector3d up = floor.up.normalized();
  // Heading: the first camera's optical axis on the floor becomes +z (any other axis if it looks
  // straight down).
  Eigen::Vector3d forward = world_from_camera.front().rotation.col(2);
  forward -= up * up.dot(forward);
  if (forward.norm() < 1e-3) {
    forward = world_from_camera.front().rotation.col(1);
    forward -= up * up.dot(forward);
  }
  forward.normalize();
  if (floor.wall) {  // snap to the walls: the wall axis nearest the camera's heading
    const Eigen::Vector3d w = (*floor.wall - up * up.dot(*floor.wall)).normalized();
    const Eigen::Vector3d axes[4] = {w, -w, up.cross(w), -up.cross(w)};
    Eigen::Vector3d snapped = axes[0];
    for (const auto& a : axes)
      if (a.dot(forward) > snapped.dot(forward)) snapped = a;
    forward = snapped;
  }
  const Eigen::Vector3d right = up.cross(forward);  // +x of the room
  Eigen::Matrix3d site_from_room;
  site_from_room.col(0) = right;
  site_from_room.col(1) = up;
  site_from_room.col(2) = forward;
  Eigen::Vector3d middle = Eigen::Vector3d::Zero();
  for (const auto& t : world_from_camera) middle += t.translation;
  middle /= static_cast<double>(world_from_camera.size());
  const Eigen::Vector3d origin = middle - up * (up.dot(middle) + floor.offset_m);  // on the floor
  RigidTransform room_from_site_t;
  room_from_site_t.rotation = site_from_room.transpose();
  room_from_site_t.translation = -(site_from_room.transpose() * origin);
  return room_from_site_t;
}

}  // namespace volcast
