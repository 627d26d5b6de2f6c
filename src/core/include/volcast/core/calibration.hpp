#pragma once
// Camera calibration: intrinsics with the Brown-Conrady rational lens model used by the Azure
// Kinect, and rigid extrinsics named by their frames (`world_from_camera`).
//
// Camera frame: x right, y down, z forward (optical axis), metres. Pixel coordinates: the centre of
// the top-left pixel is (0, 0), as in the Azure Kinect SDK ("pixelized zero-centred" output).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>

namespace volcast {

/// Intrinsics of one camera image. fx, fy, cx, cy in pixels. Distortion maps an ideal normalised
/// point (x, y) = (X/Z, Y/Z) to a distorted one (Azure Kinect SDK,
/// transformation_project_internal):
///   xp = x - codx, r2 = xp^2 + yp^2,
///   d  = (1 + k1 r2 + k2 r2^2 + k3 r2^3) / (1 + k4 r2 + k5 r2^2 + k6 r2^3),
///   xd = xp d + (r2 + 2 xp^2) p2 + 2 xp yp p1 + codx   (yd likewise with p1/p2 swapped),
///   u  = fx xd + cx, v = fy yd + cy.
/// All distortion coefficients zero = an ideal pinhole.
struct Intrinsics {
  int width = 0;   ///< image width in pixels
  int height = 0;  ///< image height in pixels
  double fx = 0, fy = 0, cx = 0, cy = 0;
  double k1 = 0, k2 = 0, k3 = 0, k4 = 0, k5 = 0, k6 = 0;
  double p1 = 0, p2 = 0;
  double codx = 0, cody = 0;
  /// Largest normalised radius for which the model is valid (Azure Kinect `MetricRadius`); points
  /// beyond it do not project. 0 = unlimited.
  double metric_radius = 0;

  bool is_pinhole() const {
    return k1 == 0 && k2 == 0 && k3 == 0 && k4 == 0 && k5 == 0 && k6 == 0 && p1 == 0 && p2 == 0 &&
           codx == 0 && cody == 0;
  }
  bool operator==(const Intrinsics&) const = default;
};

/// Projects a normalised ideal point (X/Z, Y/Z) to pixel coordinates with the lens model.
/// Returns nullopt outside the model's metric radius.
std::optional<Eigen::Vector2d> project_normalized(const Intrinsics& k, const Eigen::Vector2d& xy);

/// Inverts project_normalized for one pixel (u, v): returns (X/Z, Y/Z) of the ray through it, by
/// Newton iteration from a closed-form first guess as the Azure Kinect SDK's
/// transformation_iterative_unproject does (20 passes, accepted when the squared reprojection error
/// is below 1e-6 px^2). nullopt where the model has no solution (outside the lens' valid region).
std::optional<Eigen::Vector2d> unproject_pixel(const Intrinsics& k, const Eigen::Vector2d& uv);

/// A rigid transform target_from_source: p_target = rotation * p_source + translation.
/// Translation in metres. Compose right to left: a_from_c = a_from_b * b_from_c.
struct RigidTransform {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();  ///< metres

  static RigidTransform identity() { return {}; }
  Eigen::Vector3d operator*(const Eigen::Vector3d& p) const { return rotation * p + translation; }
  RigidTransform operator*(const RigidTransform& rhs) const {
    return {rotation * rhs.rotation, rotation * rhs.translation + translation};
  }
  RigidTransform inverse() const {
    Eigen::Matrix3d rt = rotation.transpose();
    return {rt, -(rt * translation)};
  }
  Eigen::Matrix4f matrix4f() const {
    Eigen::Matrix4f m = Eigen::Matrix4f::Identity();
    m.topLeftCorner<3, 3>() = rotation.cast<float>();
    m.topRightCorner<3, 1>() = translation.cast<float>();
    return m;
  }
};

/// Everything a viewer needs to turn one camera's depth into world-space points.
/// Color is registered to depth (same pixel grid), so one set of intrinsics serves both.
struct CameraCalibration {
  Intrinsics depth;                  ///< intrinsics of the depth image (and registered color)
  RigidTransform world_from_camera;  ///< places the depth camera in the site's world frame
};

}  // namespace volcast
