#pragma once
// Internal to volcast_calibrate: the targetless registration's global start (targetless.cpp
// registers, targetless_features.cpp gives it hypotheses): each camera's FPFH features over its
// voxelised cloud and over what of it is off its large planes, and RANSAC's hypotheses from the
// feature matches of a pair. Camera frames, metres.
#include <open3d/geometry/PointCloud.h>
#include <open3d/pipelines/registration/Feature.h>

#include <Eigen/Core>
#include <memory>
#include <vector>

#include "volcast/calibrate/targetless.hpp"
#include "volcast/core/worker_pool.hpp"

namespace volcast::targetless {

using Cloud = std::shared_ptr<open3d::geometry::PointCloud>;

/// One camera's cloud voxelised to `voxel_m`, with normals facing the camera (camera frame).
Cloud prepare(const std::vector<Eigen::Vector3d>& points, double voxel_m);

/// The rigid transform of a 4x4 matrix, its rotation re-orthonormalised (products of poses drift
/// from SO(3) by rounding).
RigidTransform rigid(const Eigen::Matrix4d& m);

// One camera's FPFH features (the global start), over its cloud voxelised to feature_voxel_m and
// over what of it is off its large planes: computed once per camera and registration, for every
// pair it is in. The clouds keep their points only: RANSAC copies its source for every hypothesis
// it scores, and reads no normals.
struct Features {
  Cloud whole, off;
  std::shared_ptr<open3d::pipelines::registration::Feature> whole_f, off_f;
};

/// `points`' features (TargetlessOptions::feature_voxel_m): computed once per camera and
/// registration, for every pair it is in.
Features compute_features(const std::vector<Eigen::Vector3d>& points, const TargetlessOptions& o);

/// FPFH + RANSAC over the whole clouds and over the off-plane points: candidate
/// target_from_source from features alone (no start), at most o.global_trials. The matches are
/// made once per kind, for every trial; each trial draws its own hypotheses (seed o.seed + trial).
std::vector<RigidTransform> global_candidates(const Features& s, const Features& d,
                                              const TargetlessOptions& o, WorkerPool& pool);

}  // namespace volcast::targetless
