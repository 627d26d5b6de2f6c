#include "volcast/viewer/xr_view.hpp"

#include <Eigen/Geometry>
#include <cmath>

namespace volcast {

RigidTransform rigid_from_xr(const XrPosef& pose) {
  const Eigen::Quaterniond q(pose.orientation.w, pose.orientation.x, pose.orientation.y,
                             pose.orientation.z);
  return {q.normalized().toRotationMatrix(),
          Eigen::Vector3d(pose.position.x, pose.position.y, pose.position.z)};
}

View xr_eye_view(const RigidTransform& world_from_stage, const XrPosef& stage_from_eye,
                 const XrFovf& fov, float near_m, float far_m) {
  return {world_from_stage * rigid_from_xr(stage_from_eye),
          perspective_from_tangents(std::tan(fov.angleLeft), std::tan(fov.angleRight),
                                    std::tan(fov.angleUp), std::tan(fov.angleDown), near_m, far_m)};
}

RigidTransform world_from_stage(const ViewCamera& start, float eye_height_m) {
  const Eigen::Vector3d up = start.up.cast<double>().normalized();
  const Eigen::Vector3d sight = (start.target - start.eye).cast<double>();
  Eigen::Vector3d forward = sight - up * sight.dot(up);
  if (!(forward.norm() > 1e-9)) forward = up.unitOrthogonal();
  forward.normalize();
  RigidTransform world_from_stage;
  world_from_stage.rotation.col(0) = forward.cross(up);  // stage x: right
  world_from_stage.rotation.col(1) = up;                 // stage y: up
  world_from_stage.rotation.col(2) = -forward;           // stage z: backward
  world_from_stage.translation = start.eye.cast<double>() - up * eye_height_m;
  return world_from_stage;
}

}  // namespace volcast
