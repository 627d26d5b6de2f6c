#pragma once
// Room alignment: the floor plane found in the registered cameras' depth sets room_from_site, so
// the site's floor lands on the virtual OR's floor. Room frame: metres, floor at y = 0, +y up
// (against gravity), origin on the floor below the middle of the cameras; +z is the first camera's
// heading (its optical axis projected onto the floor), turned onto the nearest axis of the largest
// wall when one is seen, so the room's axes run along its walls.
#include <Eigen/Core>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "volcast/core/calibration.hpp"

namespace volcast {

/// The floor, in the site's world frame.
struct FloorPlane {
  Eigen::Vector3d up = Eigen::Vector3d::UnitY();  ///< unit normal, pointing to the cameras' side
  double offset_m = 0;  ///< plane: up . p + offset_m = 0 (p in the world frame, metres)
  int inliers = 0;      ///< samples on it (voxelised)
  double rms_m = 0;     ///< RMS distance of the inliers to the plane, metres
  double share = 0;     ///< inliers / all samples
  /// How it was chosen, one line (e.g. "the large plane every camera looks down at").
  std::string reason;
  /// The normal of the largest wall seen (a large plane within 10 degrees of vertical), if any.
  std::optional<Eigen::Vector3d> wall;
};

/// Finds the floor among the largest planes of the cameras' points (`clouds` in camera frames,
/// placed by `world_from_camera`; metres): with `gravity_up` (a unit vector in the world frame,
/// e.g. from an Azure Kinect's accelerometer), the largest plane within 15 degrees of it;
/// otherwise the large plane that all cameras look down at most (OR cameras are mounted above the
/// scene, tilted down), every camera 0.2 to 4 m above it. nullopt with `why_not` set when no plane
/// qualifies (e.g. no floor in view, or a camera below the plane).
std::optional<FloorPlane> find_floor(std::span<const std::vector<Eigen::Vector3d>> clouds,
                                     std::span<const RigidTransform> world_from_camera,
                                     const std::optional<Eigen::Vector3d>& gravity_up,
                                     std::string& why_not);

/// room_from_site for `floor` (see the room frame above); `world_from_camera` gives the cameras'
/// positions (their middle) and the first camera's heading. Throws Error when it is empty.
RigidTransform room_from_site(const FloorPlane& floor,
                              std::span<const RigidTransform> world_from_camera);

}  // namespace volcast
