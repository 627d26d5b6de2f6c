#pragma once
// The Volcast lattice target and its detection in one depth image, after Mühlenbrock et al., "Fast,
// accurate and robust registration of multiple depth sensors without need for RGB and IR images"
// (The Visual Computer 2022): a rigid 3D target whose features are found in each camera's noisy
// point cloud alone (no color, no IR), then every camera's world_from_camera by least squares over
// all captures of the target. Our target's features are sphere centres on a lattice frame (a sphere
// centre is fitted to hundreds of depth samples, so it is far less noisy than any one sample); the
// design, its dimensions and how to build it are in docs/calibration-target.md.
//
// Target frame: metres; origin on the floor below the centre of the base, +y up, +x along the
// base's long side, +z completing a right-handed frame. Camera frame as in calibration.hpp (x
// right, y down, z forward, metres).
#include <Eigen/Core>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "volcast/core/calibration.hpp"
#include "volcast/core/image.hpp"
#include "volcast/core/ray_table.hpp"

namespace volcast {

/// A rigid target: spheres of one radius whose centres are the features.
struct TargetModel {
  std::string name;
  double sphere_radius_m = 0;              ///< metres
  std::vector<Eigen::Vector3d> centres_m;  ///< sphere centres in the target frame, metres
  double rod_radius_m = 0;                 ///< the frame's rods (clutter for the detector), metres
  /// The frame's rods as segments (start, end) in the target frame, metres: what holds the spheres.
  std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> rods_m;
};

/// The documented Volcast lattice target (docs/calibration-target.md): its pairwise centre
/// distances all differ by at least 40 mm, so any 3 found spheres name themselves.
TargetModel lattice_target();

/// Detector settings. Defaults suit an Azure Kinect-class ToF camera at 0.5 to 3.5 m.
struct TargetDetectOptions {
  double min_depth_m = 0.3;
  double max_depth_m = 4.0;
  /// A fitted sphere's radius may differ from the model's by this much, metres.
  double radius_tolerance_m = 0.012;
  /// Two found centres match a model pair when their distance differs by at most this, metres.
  double distance_tolerance_m = 0.015;
  int min_spheres = 3;  ///< fewer matched spheres = not found
};

/// One sphere found in the image.
struct FoundSphere {
  Eigen::Vector3d centre_m;  ///< camera frame, metres (fitted with the model's radius)
  double radius_m = 0;       ///< free-radius fit, metres (a plausibility figure)
  double rms_m = 0;          ///< RMS distance of its inlier samples to the sphere, metres
  int inliers = 0;           ///< depth samples on it
  int model_index = -1;      ///< which model sphere it is; -1 = not part of the target
};

/// What detect_target found in one depth image.
struct TargetDetection {
  bool found = false;
  /// Why not (when !found): names what was missing, e.g. "2 of 5 spheres found (need 3)".
  std::string why_not;
  std::vector<FoundSphere> spheres;   ///< every sphere candidate, matched or not
  RigidTransform camera_from_target;  ///< when found: Kabsch over the matched centres
  double rms_m = 0;  ///< when found: RMS of matched centres to the posed model, metres
  int matched = 0;   ///< spheres matched to the model
};

/// Finds `model` in one depth image (uint16 mm, 0 = invalid) whose pixels have the rays of `rays`
/// (same width and height; throws Error if they differ, or if the model has no positive radius or
/// fewer than 3 spheres). Never throws for what it does not find: returns found = false with
/// why_not. Reuses per-thread buffers (nothing allocated per pixel); single-threaded; about 2 to 8
/// ms per 640x576 image in a Release build.
TargetDetection detect_target(const DepthImage& depth, const RayTable& rays,
                              const TargetModel& model, const TargetDetectOptions& options = {});

/// One camera's view of one placement ("capture") of the target.
struct TargetObservation {
  int camera = 0;   ///< index into the site's cameras
  int capture = 0;  ///< index of the target placement
  /// Matched sphere centres: (model index, centre in the camera frame, metres).
  std::vector<std::pair<int, Eigen::Vector3d>> centres;
};

/// Every camera's pose from all observations, by least squares over all matched centres.
struct TargetSolution {
  /// Per camera; nullopt for a camera that no chain of shared captures connects to the world.
  std::vector<std::optional<RigidTransform>> world_from_camera;
  /// Per capture: where the target stood, in the world frame; nullopt if no camera saw it.
  std::vector<std::optional<RigidTransform>> world_from_target;
  std::vector<double> rms_m;          ///< per camera: RMS over its centres after the solve, metres
  std::vector<int> features;          ///< per camera: centres that entered the solve
  std::vector<std::string> problems;  ///< one line per unplaced camera, naming it and why
};

/// Solves for every camera's world_from_camera and every capture's world_from_target, minimising
/// sum || world_from_camera[c] * x - world_from_target[k] * m_j ||^2 over all observed centres
/// (alternating closed-form Kabsch steps until the change is below 1e-9 m). The world frame is the
/// target frame of the first (lowest-index) capture any camera saw -- of those joined by shared
/// captures to the most cameras, so that a stray detection cannot take the world away -- or, when
/// `reference_camera` >= 0, that camera's frame. `model` is the target the observations' model
/// indices refer to. Throws Error when an observation's camera, capture or sphere index is out of
/// range.
TargetSolution solve_target_registration(int cameras, int captures,
                                         std::span<const TargetObservation> observations,
                                         int reference_camera = -1,
                                         const TargetModel& model = lattice_target());

}  // namespace volcast
