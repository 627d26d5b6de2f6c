#include "volcast/viewer/navigation.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>

namespace volcast {
namespace {

constexpr float kToRadians = std::numbers::pi_v<float> / 180;

// `v` turned yaw_deg about `up` (unit) and then tilted toward `up` by toward_up_deg, keeping its
// length and staying kMinPitchGapDeg away from +-up.
Eigen::Vector3f turn(const Eigen::Vector3f& v, const Eigen::Vector3f& up, float yaw_deg,
                     float toward_up_deg) {
  const float length = v.norm();
  if (!(length > 0)) return v;
  const Eigen::Vector3f yawed = Eigen::AngleAxisf(yaw_deg * kToRadians, up) * v;
  Eigen::Vector3f level = yawed - up * yawed.dot(up);  // the part off `up`
  if (!(level.norm() > 1e-6f * length)) level = up.unitOrthogonal();
  level.normalize();
  const float from_up = std::acos(std::clamp(yawed.dot(up) / length, -1.0f, 1.0f));
  const float gap = kMinPitchGapDeg * kToRadians;
  const float angle =
      std::clamp(from_up - toward_up_deg * kToRadians, gap, std::numbers::pi_v<float> - gap);
  return length * (std::cos(angle) * up + std::sin(angle) * level);
}

Eigen::Vector3f unit_up(const ViewCamera& camera) {
  const float n = camera.up.norm();
  return n > 0 ? Eigen::Vector3f(camera.up / n) : Eigen::Vector3f(0, -1, 0);
}

}  // namespace

ViewCamera orbit(const ViewCamera& camera, float yaw_deg, float pitch_deg) {
  ViewCamera out = camera;
  out.eye = camera.target + turn(camera.eye - camera.target, unit_up(camera), yaw_deg, pitch_deg);
  return out;
}

ViewCamera zoom(const ViewCamera& camera, float steps) {
  const Eigen::Vector3f offset = camera.eye - camera.target;
  const float distance = offset.norm();
  if (!(distance > 0)) return camera;
  ViewCamera out = camera;
  out.eye = camera.target +
            offset / distance * std::clamp(distance * std::pow(0.85f, steps), 0.05f, 1000.0f);
  return out;
}

ViewCamera look(const ViewCamera& camera, float yaw_deg, float pitch_deg) {
  ViewCamera out = camera;
  out.target = camera.eye + turn(camera.target - camera.eye, unit_up(camera), yaw_deg, pitch_deg);
  return out;
}

ViewCamera fly(const ViewCamera& camera, const Eigen::Vector3f& right_up_forward_m) {
  const Eigen::Vector3f up = unit_up(camera);
  const Eigen::Vector3f sight = camera.target - camera.eye;
  Eigen::Vector3f forward = sight - up * sight.dot(up);
  if (!(forward.norm() > 1e-6f)) forward = up.unitOrthogonal();
  forward.normalize();
  const Eigen::Vector3f right = forward.cross(up);
  const Eigen::Vector3f move = right * right_up_forward_m.x() + up * right_up_forward_m.y() +
                               forward * right_up_forward_m.z();
  ViewCamera out = camera;
  out.eye += move;
  out.target += move;
  return out;
}

}  // namespace volcast
