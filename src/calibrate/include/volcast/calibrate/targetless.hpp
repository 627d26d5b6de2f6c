#pragma once
// Registration without a target: the cameras' depth alone, over the parts of the scene they share.
// A global start from geometric features where no pose is known (FPFH features matched by RANSAC,
// Rusu et al., ICRA 2009) -- several hypotheses per pair, each refined by ICP and kept only if it
// agrees with what both cameras saw (neither may have looked through the other's surfaces: a
// free-space check) -- then point-to-plane ICP with a robust (Tukey) loss, each camera against all
// the others together, a few rounds. The features (FPFH), normals and voxel grids are Open3D's;
// RANSAC (feature_ransac.hpp) and ICP (point_to_plane.hpp) are ours, on nanoflann's k-d trees,
// their result independent of the thread count. Positions in metres; camera frame as in
// calibration.hpp.
#include <Eigen/Core>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "volcast/core/calibration.hpp"
#include "volcast/core/image.hpp"
#include "volcast/core/ray_table.hpp"

namespace volcast {

/// The valid pixels of `depth` (uint16 mm) as points in the camera frame, metres: every `stride`-th
/// pixel in x and y, depth in [min_m, max_m]. `rays` must match the image's size (throws Error).
std::vector<Eigen::Vector3d> depth_points(const DepthImage& depth, const RayTable& rays,
                                          int stride = 1, double min_m = 0.25, double max_m = 6.0);

/// Settings; defaults suit a room seen by Azure Kinect-class cameras 1 to 5 m apart.
struct TargetlessOptions {
  double feature_voxel_m = 0.05;  ///< voxel size for FPFH features and RANSAC, metres
  /// Coarse-to-fine ICP scales, metres: voxel sizes of the first three levels (a level pairs
  /// points up to twice its voxel apart: the coarsest reaches a start 30 cm off); the last level
  /// runs on the measured samples (no voxel centroids, which would shift surfaces at edges) with
  /// this as its robust-loss scale.
  double icp_voxels_m[4] = {0.16, 0.08, 0.03, 0.01};
  /// A point has a partner in another camera when it lies within this of its surface, metres: the
  /// overlap and its RMS are measured over those points.
  double overlap_distance_m = 0.03;
  /// A pair shares enough of the scene to be registered when at least this fraction of the smaller
  /// cloud overlaps the other after registration.
  double min_overlap = 0.05;
  int ransac_iterations = 100000;  ///< RANSAC iterations per hypothesis (global start)
  int global_trials = 6;           ///< RANSAC hypotheses per pair (global start)
  /// A hypothesis is rejected when more than this share of one camera's points lie in front of
  /// what the other camera measured (it would have seen them: free-space violations).
  double max_free_space_violations = 0.05;
  double free_space_margin_m = 0.10;  ///< in front by more than this counts as a violation
  uint32_t seed = 7;                  ///< RANSAC's random seed
  /// A camera with a start keeps only alignments that end this close to it (metres, degrees).
  double start_tolerance_m = 0.35;
  double start_tolerance_deg = 15;
  int joint_rounds = 3;  ///< rounds of each camera against all others (ICP)
  /// A camera whose overlap's conditioning is below this is left unplaced (it could slide).
  double min_conditioning = 0.001;
  /// Called with each line of TargetlessResult::log as the step finishes (progress), if set.
  std::function<void(const std::string&)> progress;
};

/// Overlap between one camera and the others at some poses.
struct CameraOverlap {
  double fraction = 0;  ///< share of the camera's points with a partner in another camera
  double rms_m = 0;     ///< RMS point-to-plane distance of those points to their partners, metres
  int points = 0;       ///< points with a partner
  /// Smallest / largest eigenvalue of sum n n^T over the partners' normals: near 0 when the
  /// overlap leaves a direction of translation free (one plane, or two planes' common line).
  double conditioning = 0;
};

/// Measures each camera's overlap with all other cameras at `world_from_camera` (clouds in their
/// camera frames, metres), over at most ~60000 of each camera's samples, with normals from
/// neighbours within 3 x `voxel_m`.
std::vector<CameraOverlap> measure_overlap(std::span<const std::vector<Eigen::Vector3d>> clouds,
                                           std::span<const RigidTransform> world_from_camera,
                                           double voxel_m, double overlap_distance_m);

/// One camera as register_targetless sees it.
struct TargetlessCamera {
  std::vector<Eigen::Vector3d> cloud;  ///< its points, camera frame, metres (depth_points)
  DepthImage depth;                    ///< the depth image they came from (free-space checks)
  Intrinsics intrinsics;               ///< of `depth`
};

/// The same for cameras that may be unplaced (nullopt): they get an empty CameraOverlap and are
/// left out of the others' partners.
std::vector<CameraOverlap> measure_overlap(
    std::span<const std::vector<Eigen::Vector3d>> clouds,
    std::span<const std::optional<RigidTransform>> world_from_camera, double voxel_m,
    double overlap_distance_m);

/// The outcome of register_targetless.
struct TargetlessResult {
  /// Per camera; world = the reference camera's frame moved by its start pose (if it had one).
  /// nullopt for a camera that could not be placed (see problems).
  std::vector<std::optional<RigidTransform>> world_from_camera;
  std::vector<CameraOverlap> before;  ///< overlap at the start poses (empty without a full start)
  std::vector<CameraOverlap> after;   ///< overlap at the result
  /// Per camera: CameraOverlap::conditioning of its overlap at the result.
  std::vector<double> conditioning;
  std::vector<std::string> problems;  ///< one line per camera left unplaced or poorly constrained
  std::vector<std::string> log;       ///< what was done, a line per step (for the report)
};

/// Registers `cameras` to each other. `start` (optional, per camera) is a rough
/// world_from_camera, e.g. from the viewer's sliders (within ~20 cm / 10 degrees): a camera with
/// one is placed from its start and from the feature hypotheses, keeping only alignments that end
/// within options.start_tolerance of it; a camera without one from the feature hypotheses alone --
/// each against the cameras already placed, then all together by ICP. `reference` keeps its start
/// pose (identity when it has none). Throws Error when `start` and `cameras` differ in length or
/// the reference is out of range; never returns a transform it did not verify: a camera whose best
/// alignment overlaps less than options.min_overlap, contradicts what the other camera saw (free
/// space), or is left sliding along a plane, is nullopt, with a problem naming the camera.
TargetlessResult register_targetless(std::span<const TargetlessCamera> cameras,
                                     std::span<const std::optional<RigidTransform>> start,
                                     int reference = 0, const TargetlessOptions& options = {});

}  // namespace volcast
