#pragma once
// Private to calibrate: rows of packed doubles as a nanoflann k-d tree reads them (3-D points,
// 33-D FPFH features), with the squared L2 distance read straight from the rows: nanoflann's own
// L2 adaptor reads each element through the accessor, a call per element in the sanitized build.
#include <nanoflann.hpp>

#include <cstddef>
#include <cstdint>
#include <limits>

namespace volcast::icp {

/// `count` rows of `dims` doubles, row i at data + dims * i (a column-major Eigen matrix's columns,
/// or std::vector<Eigen::Vector3d>'s points). Not owned.
struct PackedRows {
  const double* data;
  size_t dims, count;
  size_t kdtree_get_point_count() const { return count; }
  double kdtree_get_pt(uint32_t i, size_t d) const { return data[dims * size_t{i} + d]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const {
    return false;
  }
};

/// Squared L2 distance between a query and row b. kDims > 0: rows of that many doubles (the loop
/// is unrolled); -1: PackedRows::dims, known at run time.
template <int kDims>
struct PackedL2 {
  using ElementType = double;
  using DistanceType = double;
  explicit PackedL2(const PackedRows& r) : rows(r) {}
  double evalMetric(const double* a, uint32_t b, size_t size) const {
    const size_t n = kDims > 0 ? size_t(kDims) : size;  // = rows.dims
    const double* p = rows.data + n * size_t{b};
    double sum = 0;
    for (size_t i = 0; i < n; ++i) sum += (a[i] - p[i]) * (a[i] - p[i]);
    return sum;
  }
  double accum_dist(double a, double b, size_t) const { return (a - b) * (a - b); }
  const PackedRows& rows;
};

/// A k-d tree over PackedRows (indices uint32_t), kDims as in PackedL2.
template <int kDims>
using PackedTree =
    nanoflann::KDTreeSingleIndexAdaptor<PackedL2<kDims>, PackedRows, kDims, uint32_t>;

/// nanoflann's result set for the one nearest row below a squared distance `d2` (infinity: no
/// bound): the bound prunes the search from the start (Open3D searches unbounded, then drops a
/// neighbour at or beyond the radius). `index` stays the maximum when no row is below `d2`.
struct NearestBelow {
  double d2;
  uint32_t index = std::numeric_limits<uint32_t>::max();
  bool addPoint(double dist2, uint32_t i) {
    if (dist2 < d2) {
      d2 = dist2;
      index = i;
    }
    return true;
  }
  double worstDist() const { return d2; }
  bool full() const { return true; }
};

}  // namespace volcast::icp
