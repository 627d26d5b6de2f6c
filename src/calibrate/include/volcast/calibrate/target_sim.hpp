#pragma once
// A synthetic depth camera for the registration tests and benchmarks (SYNTHETIC data, for exact
// behaviour only): ray-casts the lattice target, its frame and the floor through a real lens model
// and adds Azure Kinect-like noise.
#include <cstdint>
#include <utility>
#include <vector>

#include "volcast/calibrate/target.hpp"
#include "volcast/core/calibration.hpp"
#include "volcast/core/image.hpp"

namespace volcast {

/// Azure Kinect-like depth noise. Values after Tölgyessy et al., "Evaluation of the Azure Kinect
/// and its comparison to Kinect V1 and Kinect V2" (Sensors 2021), rounded up.
struct DepthNoise {
  double sigma_base_m = 0.0008;  ///< depth noise sigma = base + per_m2 * z^2 (z in metres)
  double sigma_per_m2 = 0.0004;
  double flying_pixels = 0.5;  ///< probability that a pixel on a depth edge is mixed
  double dropout = 0.02;       ///< probability that any pixel is invalid (0)
  double grazing_cos = 0.12;   ///< a surface seen at cos(angle) below this is invalid
  uint32_t seed = 1;
};

/// A scene: the target at `world_from_target`, a floor plane y = 0 of the world (when `floor`),
/// seen from `world_from_camera`.
struct SimScene {
  TargetModel target;
  RigidTransform world_from_target;
  bool floor = true;
  /// Other balls in the scene (decoys such as a head): world centre, radius in metres.
  std::vector<std::pair<Eigen::Vector3d, double>> extra_spheres;
};

/// world_from_camera of a camera at `eye` looking at `at` (world +y up; the camera's x right, y
/// down, z forward as in calibration.hpp), turned `roll_deg` about its optical axis. Throws Error
/// when it would look straight up or down (no "right" to speak of).
RigidTransform camera_looking_at(const Eigen::Vector3d& eye, const Eigen::Vector3d& at,
                                 double roll_deg = 0);

/// Renders the scene's depth (uint16 mm, 0 = invalid) for a camera with `intrinsics` (its lens
/// model via make_ray_table) placed at `world_from_camera`, with `noise` (all zeros = exact).
DepthImage render_sim_depth(const Intrinsics& intrinsics, const RigidTransform& world_from_camera,
                            const SimScene& scene, const DepthNoise& noise);

}  // namespace volcast
