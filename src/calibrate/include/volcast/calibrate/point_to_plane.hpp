#pragma once
// Point-to-plane ICP with a Tukey loss, and the overlap score it ends with: what Open3D's
// RegistrationICP(TransformationEstimationPointToPlane(TukeyLoss)) and EvaluateRegistration
// compute (Open3D 0.16, pipelines/registration/Registration.cpp), on a k-d tree built once per
// surface (nanoflann) instead of once per call, and with no allocation per point or iteration:
// Open3D's nearest-neighbour query allocates two vectors a point, which was most of registration's
// cost under AddressSanitizer (issue 51).
#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

namespace volcast {

class WorkerPool;

namespace icp {

/// Points with unit normals (metres, one frame) and a k-d tree over the points. Built once, then
/// read-only: queried from several threads at once. Not copyable or movable (the tree refers to
/// the points); hold it in a shared_ptr.
class Surface {
 public:
  /// `normals` is empty or as long as `points`. Throws volcast::Error otherwise.
  Surface(std::vector<Eigen::Vector3d> points, std::vector<Eigen::Vector3d> normals);
  ~Surface();
  Surface(const Surface&) = delete;
  Surface& operator=(const Surface&) = delete;

  const std::vector<Eigen::Vector3d>& points() const { return points_; }
  const std::vector<Eigen::Vector3d>& normals() const { return normals_; }

  /// Index of the point nearest `q` (surface frame) with squared distance below `max_d2` (m^2),
  /// its squared distance into `d2`; -1 when there is none (or the surface is empty).
  /// Allocation-free.
  int64_t nearest(const Eigen::Vector3d& q, double max_d2, double& d2) const;
  /// The same for q = {x, y, z}.
  int64_t nearest(const double* q, double max_d2, double& d2) const;

 private:
  struct Tree;
  std::vector<Eigen::Vector3d> points_, normals_;
  std::unique_ptr<Tree> tree_;
};

/// A surface placed in the target frame: p_target = rotation * p_surface + translation
/// (target_from_surface). A target is one or several of them (the other cameras of a room).
struct Placed {
  const Surface* surface = nullptr;
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
};

/// A target point found for a query: its squared distance (m^2), position and normal (target
/// frame; the normal is zero where the surface has none).
struct Neighbour {
  double d2 = 0;
  Eigen::Vector3d point = Eigen::Vector3d::Zero(), normal = Eigen::Vector3d::Zero();
};

/// The point of `target` nearest `q` (target frame) with squared distance below `max_d2` (m^2),
/// into `out`; false when there is none. Allocation-free.
bool nearest(std::span<const Placed> target, const Eigen::Vector3d& q, double max_d2,
             Neighbour& out);

/// The parts' points and normals in the target frame as one surface, with its own tree: a target
/// that many passes search is cheaper as one tree than as one per part.
std::shared_ptr<const Surface> merged(std::span<const Placed> parts);

/// When to stop: after `max_iterations` updates, or when an update changes both the fitness and
/// the inlier RMS (metres) by less than these (Open3D's ICPConvergenceCriteria).
struct Criteria {
  double relative_fitness = 1e-8;
  double relative_rmse = 1e-8;
  int max_iterations = 30;
};

/// A rigid fit of a source cloud to a target, and how well they agree there: `fitness` is the
/// share of the source's points with a target point closer than the correspondence distance,
/// `inlier_rms_m` the RMS of those points' distances (0 with none).
struct Fit {
  Eigen::Matrix4d target_from_source = Eigen::Matrix4d::Identity();
  double fitness = 0;
  double inlier_rms_m = 0;
};

/// Point-to-plane ICP of `source` (points in the source frame) onto `target` (surfaces with
/// normals) from `target_from_source`: each iteration pairs every source point with its nearest
/// target point within `max_distance_m`, weights the pair's point-to-plane residual r by Tukey's
/// biweight (1 - (r/k)^2)^2 for |r| < k = `tukey_k_m` (0 beyond), solves the 6x6 normal equations
/// (rotation as Z-Y-X Euler angles, then translation) and applies the update. Sums run over a
/// fixed split of the points in a fixed order, so the result does not depend on how many threads
/// `pool` has (nullptr: the calling thread alone). Throws volcast::Error on a surface without
/// normals or a distance that is not positive.
Fit point_to_plane(std::span<const Eigen::Vector3d> source, std::span<const Placed> target,
                   double max_distance_m, const Eigen::Matrix4d& target_from_source,
                   double tukey_k_m, const Criteria& criteria, WorkerPool* pool);

/// The fitness and inlier RMS of `source` placed by `target_from_source` on `target` at
/// `max_distance_m` (Open3D's EvaluateRegistration).
Fit evaluate(std::span<const Eigen::Vector3d> source, std::span<const Placed> target,
             double max_distance_m, const Eigen::Matrix4d& target_from_source, WorkerPool* pool);

}  // namespace icp
}  // namespace volcast
