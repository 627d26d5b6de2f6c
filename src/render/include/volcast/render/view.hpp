#pragma once
// What a draw pass looks through: a View places an eye in the world and says how it projects.
//
// Frames (OpenGL's conventions, so a View works unchanged for a window, an OpenXR eye and WebGL):
//   world  the site's world frame, metres (see CameraCalibration::world_from_camera).
//   view   the eye: origin at the centre of projection, x right, y up, z backward (the eye looks
//          down -z), metres.
//   clip   homogeneous clip coordinates; after the divide by w, x and y run -1..1 from the
//          viewport's left/bottom to its right/top edge and z runs -1 (near) .. 1 (far).
#include <span>

#include "volcast/core/calibration.hpp"
#include "volcast/reconstruct/point_cloud.hpp"

namespace volcast {

/// One eye's view of the world. A stereo headset has one View per eye (each with its own
/// world_from_view and, usually asymmetric, clip_from_view).
struct View {
  /// Places the view frame in the world: p_world = world_from_view * p_view. Rigid, metres.
  RigidTransform world_from_view;
  /// Projection p_clip = clip_from_view * (p_view, 1), OpenGL convention (see the top of this
  /// file); made by perspective() or perspective_from_tangents(). Identity by default, which
  /// is an orthographic view of the box |x|, |y|, |z| <= 1 m around the eye.
  Eigen::Matrix4f clip_from_view = Eigen::Matrix4f::Identity();

  /// clip_from_view * view_from_world: maps (p_world, 1) to clip coordinates.
  Eigen::Matrix4f clip_from_world() const;
};

/// A symmetric perspective projection (like gluPerspective). vertical_fov_deg: the full angle
/// between the viewport's bottom and top edges, degrees, in (0, 180). aspect: viewport width /
/// height. near_m, far_m: distances of the clipping planes in front of the eye, metres,
/// 0 < near_m < far_m. Returns clip_from_view. Throws Error naming the parameter out of range.
Eigen::Matrix4f perspective(float vertical_fov_deg, float aspect, float near_m, float far_m);

/// An off-centre perspective projection from the tangents of the angles between the view's -z
/// axis and the viewport's four edges (unitless, signed: left and down are negative when the
/// edge lies left of / below the axis). An OpenXR eye's XrFovf (angles in radians) maps to
///   perspective_from_tangents(tan(angleLeft), tan(angleRight), tan(angleUp), tan(angleDown), n, f)
/// (the same matrix as XrMatrix4x4f_CreateProjectionFov for OpenGL). A point p_view projects to
/// x_ndc = (2 * x / -z - (right + left)) / (right - left), and likewise y with up and down.
/// near_m, far_m: metres, 0 < near_m < far_m. Returns clip_from_view. Throws Error if
/// left >= right, down >= up or the clipping distances are out of range.
Eigen::Matrix4f perspective_from_tangents(float tan_left, float tan_right, float tan_up,
                                          float tan_down, float near_m, float far_m);

/// The View from a real camera's own viewpoint (the OR display draws over that camera's image):
/// world_from_view is `camera.world_from_camera` turned into the view frame (camera x right,
/// y down, z forward -> view x right, y up, z backward), and clip_from_view is the pinhole
/// intrinsics of `camera.depth` (fx, fy, cx, cy) as an off-centre perspective whose viewport edges
/// are the image's outer pixel edges (u = -0.5, u = width - 0.5, v = -0.5, v = height - 0.5;
/// pixel centres at integers, calibration.hpp). So a world point that the calibration projects to
/// pixel (u, v) (v counted from the top row) is rasterised in pixel (u, v) of a width x height
/// RenderTarget as HeadlessTarget::read_image returns it (top row first); a target of another
/// size scales the same picture. near_m, far_m: clipping distances along the optical axis,
/// metres, 0 < near_m < far_m.
/// Throws Error if the intrinsics have lens distortion (Intrinsics::is_pinhole() false: the
/// caller undistorts first, e.g. the filter chain's "undistort" (FilterConfig::undistort, or
/// make_pixel_map(source, true, ...) + apply_pixel_map in volcast/filter/filters.hpp), whose
/// output is the pinhole with the source's fx, fy, cx, cy), if the size or focal lengths are not
/// positive, or if near_m/far_m are out of range.
View camera_view(const CameraCalibration& camera, float near_m, float far_m);

/// The distance along the view's -z axis (metres, > 0 in front of the eye) of a pixel whose
/// window-space depth is `depth01` (0..1, HeadlessTarget::read_depth) under `clip_from_view`
/// (perspective or orthographic: its third and fourth rows alone decide it). Returns 0 for
/// depth01 >= 1 (nothing drawn there).
float view_depth_m(const Eigen::Matrix4f& clip_from_view, float depth01);

/// world_from_view for an eye at `eye` looking at `target`, with `up` (any vector not parallel to
/// the line of sight) showing up on screen. All in the world frame, metres. The view's -z axis
/// points from eye to target and its y axis is `up` made orthogonal to it. Throws Error if eye
/// and target coincide or up is zero or parallel to the line of sight.
RigidTransform look_at(const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
                       const Eigen::Vector3d& up);

/// A convenient way to pick a symmetric view: where the eye is, what it looks at, the field of
/// view. World frame, metres. The default up is -y because camera frames (and so an identity
/// world_from_camera) have y pointing down: the default shows the scene as camera 0 sees it.
struct ViewCamera {
  Eigen::Vector3f eye{0, 0, 0};
  Eigen::Vector3f target{0, 0, 1};
  Eigen::Vector3f up{0, -1, 0};
  float vertical_fov_deg = 60;
  float near_m = 0.05f, far_m = 100;
};

/// The View of `camera` for a viewport of width / height = `aspect`:
/// {look_at(eye, target, up), perspective(vertical_fov_deg, aspect, near_m, far_m)}.
/// Throws Error as those do.
View to_view(const ViewCamera& camera, float aspect);

/// A viewpoint that orbits a pivot starting from a camera: the pivot lies on the camera's optical
/// axis at the median depth of the points; the eye starts at `world_from_camera`'s origin and is
/// turned `yaw_deg` about the camera's up axis and `pitch_deg` about its right axis, around the
/// pivot, looking at it. Shows the scene roughly as that camera saw it, but from the side, so
/// depth is visible.
ViewCamera orbit_view(const RigidTransform& world_from_camera,
                      std::span<const PointCloud* const> clouds, float yaw_deg = 20,
                      float pitch_deg = 10);

}  // namespace volcast
