#include "volcast/calibrate/point_to_plane.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <functional>
#include <limits>

#include "packed_rows.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/worker_pool.hpp"

namespace volcast::icp {

static_assert(sizeof(Eigen::Vector3d) == 3 * sizeof(double));

struct Surface::Tree {
  // x, y, z of each point in a row (Eigen::Vector3d is three packed doubles); leaves of 15
  // points, as Open3D's KDTreeFlann builds them.
  explicit Tree(const std::vector<Eigen::Vector3d>& p)
      : points{p.empty() ? nullptr : p.front().data(), 3, p.size()},
        index(3, this->points, nanoflann::KDTreeSingleIndexAdaptorParams(15)) {}
  PackedRows points;
  PackedTree<3> index;
};

Surface::Surface(std::vector<Eigen::Vector3d> points, std::vector<Eigen::Vector3d> normals)
    : points_(std::move(points)), normals_(std::move(normals)) {
  if (!normals_.empty() && normals_.size() != points_.size())
    throw Error("icp::Surface: " + std::to_string(points_.size()) + " points but " +
                std::to_string(normals_.size()) + " normals");
  if (points_.size() >= std::numeric_limits<uint32_t>::max())
    throw Error("icp::Surface: " + std::to_string(points_.size()) + " points (at most 2^32 - 2)");
  tree_ = std::make_unique<Tree>(points_);
}

Surface::~Surface() = default;

int64_t Surface::nearest(const Eigen::Vector3d& q, double max_d2, double& d2) const {
  return nearest(q.data(), max_d2, d2);
}

int64_t Surface::nearest(const double* q, double max_d2, double& d2) const {
  if (points_.empty()) return -1;
  NearestBelow best{max_d2};
  tree_->index.findNeighbors(best, q, nanoflann::SearchParams());
  if (best.index == std::numeric_limits<uint32_t>::max()) return -1;
  d2 = best.d2;
  return best.index;
}

namespace {

// The rotations and translations of a query and its partner in plain arithmetic: they run for
// every point of every ICP iteration, where the sanitized build does not inline Eigen's
// expressions. Column-major: r[3 * column + row].
void rotate_back(const Eigen::Matrix3d& rotation, const double v[3], double out[3]) {
  const double* r = rotation.data();
  for (int i = 0; i < 3; ++i) out[i] = r[3 * i] * v[0] + r[3 * i + 1] * v[1] + r[3 * i + 2] * v[2];
}
void rotate(const Eigen::Matrix3d& rotation, const double v[3], double out[3]) {
  const double* r = rotation.data();
  for (int i = 0; i < 3; ++i) out[i] = r[i] * v[0] + r[3 + i] * v[1] + r[6 + i] * v[2];
}

}  // namespace

bool nearest(std::span<const Placed> target, const Eigen::Vector3d& q, double max_d2,
             Neighbour& out) {
  const Placed* best = nullptr;
  int64_t best_index = -1;
  double bound = max_d2;
  const double* x = q.data();
  for (const Placed& part : target) {
    const double* t = part.translation.data();
    const double centred[3] = {x[0] - t[0], x[1] - t[1], x[2] - t[2]};
    double local[3];
    rotate_back(part.rotation, centred, local);
    double d2 = 0;
    // The bound shrinks with each part's find: the later parts' searches prune more.
    const int64_t j = part.surface->nearest(local, bound, d2);
    if (j < 0) continue;
    best = &part;
    best_index = j;
    bound = d2;
  }
  if (!best) return false;
  const size_t j = static_cast<size_t>(best_index);
  out.d2 = bound;
  const double* t = best->translation.data();
  double* point = out.point.data();
  rotate(best->rotation, best->surface->points()[j].data(), point);
  for (int i = 0; i < 3; ++i) point[i] += t[i];
  if (best->surface->normals().empty())
    out.normal.setZero();
  else
    rotate(best->rotation, best->surface->normals()[j].data(), out.normal.data());
  return true;
}

std::shared_ptr<const Surface> merged(std::span<const Placed> parts) {
  size_t total = 0;
  for (const Placed& part : parts) total += part.surface->points().size();
  std::vector<Eigen::Vector3d> points, normals;
  points.reserve(total);
  normals.reserve(total);
  for (const Placed& part : parts) {
    for (const Eigen::Vector3d& p : part.surface->points())
      points.push_back(part.rotation * p + part.translation);
    for (const Eigen::Vector3d& n : part.surface->normals()) normals.push_back(part.rotation * n);
  }
  if (normals.size() != points.size()) normals.clear();  // some part had none: no normals at all
  return std::make_shared<const Surface>(std::move(points), std::move(normals));
}

namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

// What one pass over the source points gathers: the pairs and their squared distances (fitness,
// RMS) and, for an ICP step, the normal equations J^T W J x = -J^T W r.
struct Sums {
  size_t pairs = 0;
  double error2 = 0;
  double jtj[6][6] = {};  // upper triangle
  double jtr[6] = {};
  Sums& operator+=(const Sums& o) {
    pairs += o.pairs;
    error2 += o.error2;
    for (int r = 0; r < 6; ++r) {
      for (int c = r; c < 6; ++c) jtj[r][c] += o.jtj[r][c];
      jtr[r] += o.jtr[r];
    }
    return *this;
  }
};

// The points are split into this many runs, summed each on its own and then in order: the same
// sums whatever the number of threads.
constexpr size_t kRuns = 32;
// Fewer points than this are not worth waking the pool for.
constexpr size_t kParallelFrom = 4096;

// One pass over `placed` (source points in the target frame). `tukey_k_m` <= 0: pairs only.
Sums pass(std::span<const Eigen::Vector3d> placed, std::span<const Placed> target,
          double max_distance_m, double tukey_k_m, WorkerPool* pool) {
  std::array<Sums, kRuns> runs;
  const size_t n = placed.size();
  const double max_d2 = max_distance_m * max_distance_m;
  const bool steps = tukey_k_m > 0;
  const auto run = [&](size_t part) {
    Sums s;
    for (size_t i = n * part / kRuns, end = n * (part + 1) / kRuns; i < end; ++i) {
      const Eigen::Vector3d& p = placed[i];
      Neighbour partner;
      if (!nearest(target, p, max_d2, partner)) continue;
      ++s.pairs;
      s.error2 += partner.d2;
      if (!steps) continue;
      const double* a = p.data();
      const double* b = partner.point.data();
      const double* m = partner.normal.data();
      const double residual = (a[0] - b[0]) * m[0] + (a[1] - b[1]) * m[1] + (a[2] - b[2]) * m[2];
      const double e = std::abs(residual) / tukey_k_m;
      if (e >= 1) continue;  // weight 0
      const double weight = (1 - e * e) * (1 - e * e);
      // d residual / d (rotation, translation): (p x n, n).
      const double jacobian[6] = {a[1] * m[2] - a[2] * m[1],
                                  a[2] * m[0] - a[0] * m[2],
                                  a[0] * m[1] - a[1] * m[0],
                                  m[0],
                                  m[1],
                                  m[2]};
      for (int r = 0; r < 6; ++r) {
        const double wj = weight * jacobian[r];
        for (int c = r; c < 6; ++c) s.jtj[r][c] += wj * jacobian[c];  // upper triangle
        s.jtr[r] += wj * residual;
      }
    }
    runs[part] = s;
  };
  if (pool && n >= kParallelFrom) {
    const std::function<void(size_t)> fn(std::ref(run));  // no allocation: a reference
    pool->parallel_for(kRuns, fn);
  } else {
    for (size_t r = 0; r < kRuns; ++r) run(r);
  }
  Sums total;
  for (const Sums& s : runs) total += s;
  return total;
}

Fit scored(const Eigen::Matrix4d& target_from_source, const Sums& s, size_t points) {
  Fit f;
  f.target_from_source = target_from_source;
  f.fitness = points ? static_cast<double>(s.pairs) / static_cast<double>(points) : 0;
  f.inlier_rms_m = s.pairs ? std::sqrt(s.error2 / static_cast<double>(s.pairs)) : 0;
  return f;
}

// The rigid update that solves the normal equations (Open3D's
// SolveJacobianSystemAndObtainExtrinsicMatrix: LDLT, x = (alpha, beta, gamma, t), R = Rz Ry Rx);
// the identity with no pairs or no finite solution.
Eigen::Matrix4d step(const Sums& s) {
  Eigen::Matrix4d update = Eigen::Matrix4d::Identity();
  if (s.pairs == 0) return update;
  Matrix6d jtj;
  Vector6d jtr;
  for (int r = 0; r < 6; ++r) {
    for (int c = r; c < 6; ++c) jtj(r, c) = jtj(c, r) = s.jtj[r][c];
    jtr(r) = s.jtr[r];
  }
  const Vector6d x = jtj.ldlt().solve(-jtr);
  if (!x.allFinite()) return update;
  update.topLeftCorner<3, 3>() = (Eigen::AngleAxisd(x(2), Eigen::Vector3d::UnitZ()) *
                                  Eigen::AngleAxisd(x(1), Eigen::Vector3d::UnitY()) *
                                  Eigen::AngleAxisd(x(0), Eigen::Vector3d::UnitX()))
                                     .toRotationMatrix();
  update.topRightCorner<3, 1>() = x.tail<3>();
  return update;
}

void move_points(const Eigen::Matrix4d& m, std::span<Eigen::Vector3d> points) {
  const Eigen::Matrix3d rotation = m.topLeftCorner<3, 3>();
  const double* t = m.data() + 12;  // column 3
  for (Eigen::Vector3d& p : points) {
    const double v[3] = {p.x(), p.y(), p.z()};
    rotate(rotation, v, p.data());
    for (int i = 0; i < 3; ++i) p.data()[i] += t[i];
  }
}

}  // namespace

Fit point_to_plane(std::span<const Eigen::Vector3d> source, std::span<const Placed> target,
                   double max_distance_m, const Eigen::Matrix4d& target_from_source,
                   double tukey_k_m, const Criteria& criteria, WorkerPool* pool) {
  for (const Placed& part : target)
    if (part.surface->normals().size() != part.surface->points().size())
      throw Error("icp::point_to_plane: a target surface has no normals");
  if (!(max_distance_m > 0) || !(tukey_k_m > 0))
    throw Error("icp::point_to_plane: the correspondence distance and Tukey's k must be > 0 m");
  std::vector<Eigen::Vector3d> placed(source.begin(), source.end());
  Eigen::Matrix4d t = target_from_source;
  move_points(t, placed);
  Sums sums = pass(placed, target, max_distance_m, tukey_k_m, pool);
  Fit fit = scored(t, sums, placed.size());
  for (int i = 0; i < criteria.max_iterations; ++i) {
    const Eigen::Matrix4d update = step(sums);
    t = update * t;
    move_points(update, placed);
    const Fit before = fit;
    sums = pass(placed, target, max_distance_m, tukey_k_m, pool);
    fit = scored(t, sums, placed.size());
    if (std::abs(before.fitness - fit.fitness) < criteria.relative_fitness &&
        std::abs(before.inlier_rms_m - fit.inlier_rms_m) < criteria.relative_rmse)
      break;
  }
  return fit;
}

Fit evaluate(std::span<const Eigen::Vector3d> source, std::span<const Placed> target,
             double max_distance_m, const Eigen::Matrix4d& target_from_source, WorkerPool* pool) {
  std::vector<Eigen::Vector3d> placed(source.begin(), source.end());
  move_points(target_from_source, placed);
  return scored(target_from_source, pass(placed, target, max_distance_m, 0, pool), placed.size());
}

}  // namespace volcast::icp
