#include "volcast/calibrate/feature_ransac.hpp"

#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <string>

#include "packed_rows.hpp"
#include "volcast/calibrate/point_to_plane.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/worker_pool.hpp"

namespace volcast::icp {
namespace {

// Leaves of this many features: in 33 dimensions a search visits many leaves, and a longer leaf
// (a tight loop) costs less than the tree walk to more, shorter ones.
constexpr size_t kLeaf = 48;
using FeatureTree = PackedTree<-1>;

// For each column of `queries`, the nearest column of `tree`'s features.
std::vector<int> nearest_columns(const FeatureTree& tree, const Eigen::MatrixXd& queries) {
  std::vector<int> out(static_cast<size_t>(queries.cols()));
  for (Eigen::Index i = 0; i < queries.cols(); ++i) {
    NearestBelow best{std::numeric_limits<double>::infinity()};  // the tree is not empty
    tree.findNeighbors(best, queries.data() + i * queries.rows(), nanoflann::SearchParams());
    out[static_cast<size_t>(i)] = static_cast<int>(best.index);
  }
  return out;
}

}  // namespace

std::vector<std::pair<int, int>> match_features(const Eigen::MatrixXd& source_features,
                                                const Eigen::MatrixXd& target_features) {
  if (source_features.rows() != target_features.rows())
    throw Error("match_features: source features have " + std::to_string(source_features.rows()) +
                " dimensions, target features " + std::to_string(target_features.rows()));
  const size_t dims = static_cast<size_t>(source_features.rows());
  if (source_features.cols() == 0 || target_features.cols() == 0 || dims == 0) return {};
  const PackedRows s{source_features.data(), dims, static_cast<size_t>(source_features.cols())};
  const PackedRows d{target_features.data(), dims, static_cast<size_t>(target_features.cols())};
  const FeatureTree tree_s(static_cast<int>(dims), s,
                           nanoflann::KDTreeSingleIndexAdaptorParams(kLeaf));
  const FeatureTree tree_d(static_cast<int>(dims), d,
                           nanoflann::KDTreeSingleIndexAdaptorParams(kLeaf));
  const std::vector<int> s_to_d = nearest_columns(tree_d, source_features);
  const std::vector<int> d_to_s = nearest_columns(tree_s, target_features);
  std::vector<std::pair<int, int>> out;
  for (size_t i = 0; i < s_to_d.size(); ++i)
    if (d_to_s[static_cast<size_t>(s_to_d[i])] == static_cast<int>(i))
      out.emplace_back(static_cast<int>(i), s_to_d[i]);
  if (out.size() < 9) {  // ransac_n (3) x 3, as Open3D falls back
    out.clear();
    for (size_t i = 0; i < s_to_d.size(); ++i) out.emplace_back(static_cast<int>(i), s_to_d[i]);
  }
  return out;
}

namespace {

// SplitMix64 (Steele et al., "Fast splittable pseudorandom number generators", OOPSLA 2014): the
// k-th value of hypothesis h's stream from the seed alone, with no state shared between threads.
uint64_t mix(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// Hypotheses scored between two looks at the stopping rule: the fixed batch keeps the choice
// independent of the thread count.
constexpr int kBatch = 64;

struct Hypothesis {
  bool kept = false;
  Eigen::Matrix4d target_from_source = Eigen::Matrix4d::Identity();
  size_t inliers = 0;
  double error2 = 0;
};

bool better(const Hypothesis& a, const Hypothesis& b, size_t points) {
  if (!b.kept) return a.kept;
  if (!a.kept || a.inliers == 0) return false;
  const double fa = static_cast<double>(a.inliers) / static_cast<double>(points);
  const double fb = static_cast<double>(b.inliers) / static_cast<double>(points);
  if (fa != fb) return fa > fb;
  const double ra = std::sqrt(a.error2 / static_cast<double>(a.inliers));
  const double rb = b.inliers ? std::sqrt(b.error2 / static_cast<double>(b.inliers)) : 0;
  return ra < rb;
}

}  // namespace

std::optional<RansacFit> ransac_rigid(const Matches& matches, const RansacOptions& o,
                                      WorkerPool* pool) {
  const size_t n = matches.source.size();
  if (matches.target.size() != n)
    throw Error("ransac_rigid: " + std::to_string(n) + " source points but " +
                std::to_string(matches.target.size()) + " target points");
  if (n < 3 || !(o.max_distance_m > 0)) return std::nullopt;
  const Surface target(matches.target, {});
  const std::vector<Placed> placed = {{&target}};
  const double max_d2 = o.max_distance_m * o.max_distance_m;

  const auto hypothesis = [&](int index, Hypothesis& h) {
    h = Hypothesis{};
    std::array<size_t, 3> pick{};
    uint64_t state = mix(uint64_t{o.seed} << 32 ^ static_cast<uint64_t>(index));
    for (size_t k = 0; k < 3; ++k) {  // three distinct matches
      do {
        state = mix(state);
        pick[k] = static_cast<size_t>(state % n);
      } while ((k > 0 && pick[k] == pick[0]) || (k > 1 && pick[k] == pick[1]));
    }
    Eigen::Matrix3d src, dst;
    for (int k = 0; k < 3; ++k) {
      src.col(k) = matches.source[pick[static_cast<size_t>(k)]];
      dst.col(k) = matches.target[pick[static_cast<size_t>(k)]];
    }
    for (int a = 0; a < 3; ++a)
      for (int b = a + 1; b < 3; ++b) {
        const double ds = (src.col(a) - src.col(b)).norm(), dt = (dst.col(a) - dst.col(b)).norm();
        if (ds < dt * o.edge_similarity || dt < ds * o.edge_similarity) return;
      }
    const Eigen::Matrix4d t = Eigen::umeyama(src, dst, false);
    if (!t.allFinite()) return;
    const Eigen::Matrix3d r = t.topLeftCorner<3, 3>();
    const Eigen::Vector3d shift = t.topRightCorner<3, 1>();
    for (int k = 0; k < 3; ++k)
      if ((r * src.col(k) + shift - dst.col(k)).norm() > o.max_distance_m) return;
    h.kept = true;
    h.target_from_source = t;
    Neighbour partner;
    for (const Eigen::Vector3d& p : matches.source) {
      if (!nearest(placed, r * p + shift, max_d2, partner)) continue;
      ++h.inliers;
      h.error2 += partner.d2;
    }
  };

  Hypothesis best;
  std::array<Hypothesis, kBatch> batch;
  int needed = o.max_iterations;
  for (int first = 0; first < needed; first += kBatch) {
    const int count = std::min(kBatch, needed - first);
    const auto run = [&](size_t i) { hypothesis(first + static_cast<int>(i), batch[i]); };
    if (pool) {
      const std::function<void(size_t)> fn(std::ref(run));
      pool->parallel_for(static_cast<size_t>(count), fn);
    } else {
      for (size_t i = 0; i < static_cast<size_t>(count); ++i) run(i);
    }
    bool improved = false;
    for (int i = 0; i < count; ++i)
      if (better(batch[static_cast<size_t>(i)], best, n)) {
        best = batch[static_cast<size_t>(i)];
        improved = true;
      }
    if (!improved) continue;
    // Open3D's stopping rule: enough hypotheses that one of three inlier matches is drawn with
    // `confidence`, from the best one's share of matches whose points it brings within reach.
    const Eigen::Matrix3d r = best.target_from_source.topLeftCorner<3, 3>();
    const Eigen::Vector3d shift = best.target_from_source.topRightCorner<3, 1>();
    size_t agree = 0;
    for (size_t k = 0; k < n; ++k)
      if ((r * matches.source[k] + shift - matches.target[k]).squaredNorm() < max_d2) ++agree;
    const double ratio = static_cast<double>(agree) / static_cast<double>(n);
    const double k = std::log(1 - o.confidence) / std::log(1 - ratio * ratio * ratio);
    if (std::isfinite(k) && k < needed) needed = static_cast<int>(std::ceil(k));
  }
  if (!best.kept || best.inliers == 0) return std::nullopt;
  RansacFit fit;
  fit.target_from_source = best.target_from_source;
  fit.inliers = best.inliers;
  fit.fitness = static_cast<double>(best.inliers) / static_cast<double>(n);
  fit.inlier_rms_m = std::sqrt(best.error2 / static_cast<double>(best.inliers));
  return fit;
}

}  // namespace volcast::icp
