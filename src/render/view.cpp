#include "volcast/render/view.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "volcast/core/error.hpp"

namespace volcast {
namespace {

void check_clip_distances(const char* what, float near_m, float far_m) {
  if (!(near_m > 0) || !(far_m > near_m) || !std::isfinite(far_m))
    throw Error(fmt::format("{}: needs 0 < near_m < far_m (finite), got near_m {} and far_m {}",
                            what, near_m, far_m));
}

}  // namespace

Eigen::Matrix4f View::clip_from_world() const {
  return clip_from_view * world_from_view.inverse().matrix4f();
}

Eigen::Matrix4f perspective(float vertical_fov_deg, float aspect, float near_m, float far_m) {
  if (!(vertical_fov_deg > 0 && vertical_fov_deg < 180))
    throw Error(
        fmt::format("perspective: vertical_fov_deg must be in (0, 180), got {}", vertical_fov_deg));
  if (!(aspect > 0) || !std::isfinite(aspect))
    throw Error(fmt::format("perspective: aspect (width / height) must be > 0, got {}", aspect));
  check_clip_distances("perspective", near_m, far_m);
  const float half_height = std::tan(vertical_fov_deg * std::numbers::pi_v<float> / 360.0f);
  const float half_width = half_height * aspect;
  return perspective_from_tangents(-half_width, half_width, half_height, -half_height, near_m,
                                   far_m);
}

Eigen::Matrix4f perspective_from_tangents(float tan_left, float tan_right, float tan_up,
                                          float tan_down, float near_m, float far_m) {
  if (!(tan_left < tan_right) || !std::isfinite(tan_left) || !std::isfinite(tan_right))
    throw Error(fmt::format("perspective_from_tangents: needs tan_left < tan_right, got {} and {}",
                            tan_left, tan_right));
  if (!(tan_down < tan_up) || !std::isfinite(tan_down) || !std::isfinite(tan_up))
    throw Error(fmt::format("perspective_from_tangents: needs tan_down < tan_up, got {} and {}",
                            tan_down, tan_up));
  check_clip_distances("perspective_from_tangents", near_m, far_m);
  const float width = tan_right - tan_left, height = tan_up - tan_down;
  Eigen::Matrix4f p = Eigen::Matrix4f::Zero();
  p(0, 0) = 2 / width;
  p(0, 2) = (tan_right + tan_left) / width;
  p(1, 1) = 2 / height;
  p(1, 2) = (tan_up + tan_down) / height;
  p(2, 2) = (far_m + near_m) / (near_m - far_m);
  p(2, 3) = 2 * far_m * near_m / (near_m - far_m);
  p(3, 2) = -1;
  return p;
}

View camera_view(const CameraCalibration& camera, float near_m, float far_m) {
  const Intrinsics& k = camera.depth;
  if (!k.is_pinhole())
    throw Error(
        "camera_view: the camera's intrinsics have lens distortion; undistort its images first "
        "(the filter chain's undistort gives the pinhole with the same fx, fy, cx, cy)");
  if (k.width <= 0 || k.height <= 0 || !(k.fx > 0) || !(k.fy > 0))
    throw Error(
        fmt::format("camera_view: needs a positive size and focal lengths, got {}x{} "
                    "pixels, fx {}, fy {}",
                    k.width, k.height, k.fx, k.fy));
  check_clip_distances("camera_view", near_m, far_m);
  RigidTransform camera_from_view;  // view x right, y up, z backward; camera y down, z forward
  camera_from_view.rotation = Eigen::Vector3d(1, -1, -1).asDiagonal();
  // Tangents of the image's outer pixel edges: u = -0.5 (left) .. width - 0.5 (right); v = -0.5
  // is the top edge, where the camera's y = (v - cy) / fy * z is most negative (view y up).
  const double left = (-0.5 - k.cx) / k.fx, right = (k.width - 0.5 - k.cx) / k.fx;
  const double up = (k.cy + 0.5) / k.fy, down = -(k.height - 0.5 - k.cy) / k.fy;
  return {
      camera.world_from_camera * camera_from_view,
      perspective_from_tangents(static_cast<float>(left), static_cast<float>(right),
                                static_cast<float>(up), static_cast<float>(down), near_m, far_m)};
}

RigidTransform look_at(const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
                       const Eigen::Vector3d& up) {
  const Eigen::Vector3d line_of_sight = target - eye;
  if (!(line_of_sight.norm() > 1e-9))
    throw Error("look_at: eye and target coincide, so there is no direction to look in");
  const Eigen::Vector3d backward = -line_of_sight.normalized();  // the view's z axis
  const Eigen::Vector3d right = up.cross(backward);              // the view's x axis
  if (!(right.norm() > 1e-9 * std::max(1.0, up.norm())))
    throw Error("look_at: up is zero or parallel to the line of sight");
  RigidTransform world_from_view;
  world_from_view.rotation.col(0) = right.normalized();
  world_from_view.rotation.col(2) = backward;
  world_from_view.rotation.col(1) = backward.cross(world_from_view.rotation.col(0));
  world_from_view.translation = eye;
  return world_from_view;
}

View to_view(const ViewCamera& camera, float aspect) {
  return {
      look_at(camera.eye.cast<double>(), camera.target.cast<double>(), camera.up.cast<double>()),
      perspective(camera.vertical_fov_deg, aspect, camera.near_m, camera.far_m)};
}

ViewCamera orbit_view(const RigidTransform& world_from_camera,
                      std::span<const PointCloud* const> clouds, float yaw_deg, float pitch_deg) {
  const Eigen::Vector3d eye = world_from_camera.translation;
  const Eigen::Vector3d forward = world_from_camera.rotation * Eigen::Vector3d(0, 0, 1);
  const Eigen::Vector3d up = world_from_camera.rotation * Eigen::Vector3d(0, -1, 0);
  const Eigen::Vector3d right = world_from_camera.rotation * Eigen::Vector3d(1, 0, 0);
  // Pivot at the median distance along the camera's axis (robust to a far floor or wall).
  std::vector<float> along;
  for (const PointCloud* c : clouds)
    for (size_t i = 0; i < c->points.size(); i += 16) {
      const float* p = c->points[i].position;
      along.push_back(static_cast<float>((Eigen::Vector3d(p[0], p[1], p[2]) - eye).dot(forward)));
    }
  double distance = 1.0;
  if (!along.empty()) {
    std::nth_element(along.begin(), along.begin() + static_cast<std::ptrdiff_t>(along.size() / 2),
                     along.end());
    distance = std::max(0.3, static_cast<double>(along[along.size() / 2]));
  }
  const Eigen::Vector3d pivot = eye + forward * distance;
  const double to_rad = std::numbers::pi / 180;
  const Eigen::Matrix3d turn =
      (Eigen::AngleAxisd(yaw_deg * to_rad, up) * Eigen::AngleAxisd(-pitch_deg * to_rad, right))
          .toRotationMatrix();
  ViewCamera v;
  v.target = pivot.cast<float>();
  v.eye = (pivot + turn * (eye - pivot)).cast<float>();
  v.up = up.cast<float>();
  return v;
}

float view_depth_m(const Eigen::Matrix4f& clip_from_view, float depth01) {
  if (!(depth01 < 1.0f)) return 0;
  // ndc = (P22 z + P23) / (P32 z + P33) for view z (negative in front); solved for z.
  const float ndc = 2.0f * depth01 - 1.0f;
  const Eigen::Matrix4f& p = clip_from_view;
  const float z = (p(2, 3) - ndc * p(3, 3)) / (ndc * p(3, 2) - p(2, 2));
  return -z;
}

}  // namespace volcast
