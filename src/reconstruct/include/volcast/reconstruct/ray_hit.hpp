#pragma once
// Where a ray (a participant's laser pointer) first meets the live surfaces, as the cameras
// measured them: marched against each camera's depth image, not against a mesh or a guess.
//
// The rule (one camera): samples at t = 0, s, 2s, ... up to max_distance_m along the ray
// (s = RayMarch::step_m, larger when max_steps would be exceeded). Each sample is put into the
// camera frame and projected with the camera's lens model (project_normalized, distortion
// included) to its nearest depth pixel; it is *measurable* when it lies in front of the camera
// (Z > 0), inside the lens model and the image, on a pixel with valid depth (not 0), and then its
// gap is g = Z - measured depth (metres; Z is along the optical axis, as depth is).
//  - g < 0: the sample lies in front of the measured surface (free space the camera saw).
//  - g >= 0: it lies behind. When a measurable sample with g >= 0 follows one with g < 0, the
//    point between them where the ray goes from in front to behind is found by bisection (to
//    0.01 mm; a midpoint that is not measurable counts as behind). The ray hit the surface there
//    when the sample just behind that point is measurable and at most behind_tolerance_m behind
//    its pixel's surface (a continuous surface gives ~0). More means the ray's image crossed a
//    silhouette edge while the ray was deeper than the surface in front: it went into the region
//    hidden behind that surface (e.g. behind a hand), which the camera cannot see. That is not a
//    hit; marching goes on, and the ray may hit a surface further on after coming out in front
//    of it (a ray passing behind a hand hits the patient below it).
// A sample that is not measurable breaks the pair: a hit needs a measured in-front sample right
// before it, so invalid depth never hits, and a ray that starts behind a surface, or comes out
// of the hidden region towards the camera, does not hit it from behind (the camera did not see
// that side; another camera may). The step only has to be small enough not to step over a
// surface the ray goes behind and comes out of again within one step. Work is bounded (at most
// max_steps + 1 samples, 24 bisection steps per crossing) and allocation-free.
#include <Eigen/Core>
#include <cstddef>
#include <optional>
#include <span>

#include "volcast/core/calibration.hpp"
#include "volcast/core/image.hpp"

namespace volcast {

/// How a ray is marched (see the top of this file).
struct RayMarch {
  float step_m = 0.004f;  ///< distance between samples, metres, > 0
  /// How far behind a measured surface (metres, >= 0) the ray may be just where it went from in
  /// front to behind and still count as going through it; more is a silhouette edge. A few
  /// centimetres: more than the depth noise and a depth pixel's slope on a slanted surface, less
  /// than the gap between a hand and the patient below it.
  float behind_tolerance_m = 0.04f;
  int max_steps = 4096;  ///< most steps marched, >= 1; the step grows to max_distance / max_steps
};

/// Where a ray meets a measured surface.
struct RayHit {
  Eigen::Vector3f point_world = Eigen::Vector3f::Zero();  ///< on the ray, world frame, metres
  float distance_m = 0;          ///< from the ray's origin to point_world, metres
  int pixel_x = 0, pixel_y = 0;  ///< the depth pixel whose surface it met (0,0 = top left)
  size_t camera = 0;             ///< index of that camera (hit_depths; 0 for hit_depth)
};

/// The first hit of the ray origin_world + t * direction_world (world frame, metres; direction
/// any length, normalised here), 0 <= t <= max_distance_m, on the surface `camera` measured in
/// `depth` (uint16 mm, 0 = invalid, the calibration's size), or nullopt. Throws Error if the depth
/// image's size differs from the calibration's, the origin or direction is not finite, the
/// direction is zero, max_distance_m is negative or not finite, or a RayMarch field is out of
/// range.
std::optional<RayHit> hit_depth(const CameraCalibration& camera, const DepthImage& depth,
                                const Eigen::Vector3f& origin_world,
                                const Eigen::Vector3f& direction_world, float max_distance_m,
                                const RayMarch& march = {});

/// The nearest hit over several cameras: camera i's calibration is cameras[i] and its depth
/// depths[i] (null: no image yet, skipped); RayHit::camera names the one hit. Throws Error if the
/// spans differ in length, or as hit_depth does.
std::optional<RayHit> hit_depths(std::span<const CameraCalibration> cameras,
                                 std::span<const DepthImage* const> depths,
                                 const Eigen::Vector3f& origin_world,
                                 const Eigen::Vector3f& direction_world, float max_distance_m,
                                 const RayMarch& march = {});

}  // namespace volcast
