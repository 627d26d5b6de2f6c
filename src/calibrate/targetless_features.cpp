// The targetless registration's global start (targetless_features.hpp): Open3D's FPFH features,
// our matching and RANSAC (feature_ransac.hpp).
#include "targetless_features.hpp"

#include <Eigen/SVD>
#include <optional>

#include "volcast/calibrate/feature_ransac.hpp"

namespace volcast::targetless {
namespace {

namespace o3g = open3d::geometry;
namespace o3r = open3d::pipelines::registration;

// The points of `cloud` off its largest planes (floor, walls, ceiling): the furniture and
// people that tell one place from another, where the planes match almost anywhere.
std::vector<size_t> off_planes(const o3g::PointCloud& cloud) {
  std::vector<bool> on(cloud.points_.size(), false);
  auto rest = std::make_shared<o3g::PointCloud>(cloud);
  std::vector<size_t> index(cloud.points_.size());
  for (size_t i = 0; i < index.size(); ++i) index[i] = i;
  for (int k = 0; k < 4; ++k) {
    if (rest->points_.size() < 100) break;
    const auto [plane, inliers] = rest->SegmentPlane(0.04, 3, 500);
    if (inliers.size() < cloud.points_.size() / 12) break;
    std::vector<size_t> keep;
    std::vector<bool> is_in(rest->points_.size(), false);
    for (size_t i : inliers) is_in[i] = true;
    for (size_t i = 0; i < index.size(); ++i)
      if (is_in[i])
        on[index[i]] = true;
      else
        keep.push_back(index[i]);
    rest = rest->SelectByIndex(inliers, true);
    index = keep;
  }
  std::vector<size_t> out;
  for (size_t i = 0; i < on.size(); ++i)
    if (!on[i]) out.push_back(i);
  return out;
}

std::shared_ptr<o3r::Feature> select(const o3r::Feature& f, const std::vector<size_t>& index) {
  auto out = std::make_shared<o3r::Feature>();
  out->Resize(static_cast<int>(f.Dimension()), static_cast<int>(index.size()));
  for (size_t i = 0; i < index.size(); ++i)
    out->data_.col(static_cast<long>(i)) = f.data_.col(static_cast<long>(index[i]));
  return out;
}

// What RANSAC draws from: the feature matches of `s` into `d` (match_features), as matched
// points: point k of `source` and of `target` is match k.
icp::Matches match(const o3g::PointCloud& s, const o3g::PointCloud& d, const o3r::Feature& fs,
                   const o3r::Feature& fd) {
  icp::Matches m;
  for (const auto& [i, j] : icp::match_features(fs.data_, fd.data_)) {
    m.source.push_back(s.points_[static_cast<size_t>(i)]);
    m.target.push_back(d.points_[static_cast<size_t>(j)]);
  }
  return m;
}

}  // namespace

Cloud prepare(const std::vector<Eigen::Vector3d>& points, double voxel_m) {
  o3g::PointCloud raw(points);
  Cloud down = raw.VoxelDownSample(voxel_m);
  down->EstimateNormals(o3g::KDTreeSearchParamHybrid(voxel_m * 3, 30));
  down->OrientNormalsTowardsCameraLocation(Eigen::Vector3d::Zero());
  return down;
}

RigidTransform rigid(const Eigen::Matrix4d& m) {
  RigidTransform t;
  // Re-orthonormalise: the pose graph's and ICP's products drift from SO(3) by rounding.
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(m.topLeftCorner<3, 3>(),
                                        Eigen::ComputeFullU | Eigen::ComputeFullV);
  t.rotation = svd.matrixU() * svd.matrixV().transpose();
  t.translation = m.topRightCorner<3, 1>();
  return t;
}

Features compute_features(const std::vector<Eigen::Vector3d>& points, const TargetlessOptions& o) {
  const double v = o.feature_voxel_m;
  const Cloud s = prepare(points, v);
  Features f;
  f.whole_f = o3r::ComputeFPFHFeature(*s, o3g::KDTreeSearchParamHybrid(v * 5, 100));
  const auto index = off_planes(*s);
  f.off_f = select(*f.whole_f, index);
  f.whole = std::make_shared<o3g::PointCloud>(s->points_);
  f.off = f.whole->SelectByIndex(index);
  return f;
}

std::vector<RigidTransform> global_candidates(const Features& s, const Features& d,
                                              const TargetlessOptions& o, WorkerPool& pool) {
  std::optional<icp::Matches> whole_m, off_m;
  std::vector<RigidTransform> out;
  for (int trial = 0; trial < o.global_trials; ++trial) {
    // Alternate: features over the whole cloud, and over what is off its large planes.
    const bool whole = trial % 2 == 0;
    std::optional<icp::Matches>& m = whole ? whole_m : off_m;
    if (!m)
      m = whole ? match(*s.whole, *d.whole, *s.whole_f, *d.whole_f)
                : match(*s.off, *d.off, *s.off_f, *d.off_f);
    icp::RansacOptions r;
    r.max_distance_m = o.feature_voxel_m * 1.5;
    r.max_iterations = o.ransac_iterations;
    r.seed = o.seed + static_cast<uint32_t>(trial);
    const auto fit = icp::ransac_rigid(*m, r, &pool);
    if (fit && fit->inliers >= 10) out.push_back(rigid(fit->target_from_source));
  }
  return out;
}

}  // namespace volcast::targetless
