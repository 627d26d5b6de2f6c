#pragma once
// The global start of targetless registration: feature matches between two clouds and a rigid
// transform from them by RANSAC, as Open3D's RegistrationRANSACBasedOnFeatureMatching builds them
// (Open3D 0.16, pipelines/registration/Registration.cpp; Rusu et al., "Fast Point Feature
// Histograms (FPFH) for 3D registration", ICRA 2009) -- but with a k-d tree built once per call
// and no allocation per hypothesis, and with sums and choices in a fixed order, so the result
// does not depend on the number of threads (issue 51).
#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <vector>

namespace volcast {

class WorkerPool;

namespace icp {

/// Point k of `source` (source frame, metres) matches point k of `target` (target frame).
struct Matches {
  std::vector<Eigen::Vector3d> source, target;
};

/// The matches of features `source_features` into `target_features` (one feature per column,
/// both with as many rows; FPFH: 33): each source feature to its nearest target feature, kept
/// where that target feature's nearest source feature is the same one (mutual); all of them when
/// fewer than 9 are mutual (Open3D's fallback). Returns (source column, target column) pairs.
/// Throws volcast::Error when the row counts differ.
std::vector<std::pair<int, int>> match_features(const Eigen::MatrixXd& source_features,
                                                const Eigen::MatrixXd& target_features);

struct RansacOptions {
  double max_distance_m = 0.075;  ///< a source point is an inlier within this of a target point
  double edge_similarity = 0.9;   ///< a sample's edges in the two clouds agree to this ratio
  int max_iterations = 100000;    ///< hypotheses drawn at most
  double confidence = 0.9999;     ///< stop once a better one is this unlikely
  uint32_t seed = 7;              ///< the samples are a function of the seed and their index
};

/// The best hypothesis found: target_from_source, the share of `matches.source` with a point of
/// `matches.target` within max_distance_m once placed (fitness), their RMS distance (m) and count.
struct RansacFit {
  Eigen::Matrix4d target_from_source = Eigen::Matrix4d::Identity();
  double fitness = 0;
  double inlier_rms_m = 0;
  size_t inliers = 0;
};

/// RANSAC over `matches`: three distinct matches drawn per hypothesis, kept when their edges agree
/// (edge_similarity) and, once aligned (Umeyama, no scale), each lies within max_distance_m of its
/// partner; scored by fitness against all matched target points (ties: the lower RMS, then the
/// earlier hypothesis). Stops after the number of hypotheses the best one's inlier ratio makes
/// enough for `confidence`. Hypotheses are scored in parallel on `pool` (nullptr: the caller
/// alone). nullopt with fewer than 3 matches or no hypothesis kept.
std::optional<RansacFit> ransac_rigid(const Matches& matches, const RansacOptions& options,
                                      WorkerPool* pool);

}  // namespace icp
}  // namespace volcast
