#include "volcast/calibrate/targetless.hpp"

#include <open3d/geometry/PointCloud.h>
#include <open3d/pipelines/registration/Feature.h>
#include <open3d/utility/Logging.h>
#include <open3d/utility/Random.h>
#include <spdlog/fmt/fmt.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <memory>

#include "targetless_features.hpp"
#include "volcast/calibrate/point_to_plane.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/worker_pool.hpp"

namespace volcast {
namespace {

namespace o3g = open3d::geometry;
using targetless::Cloud;
using targetless::compute_features;
using targetless::Features;
using targetless::global_candidates;
using targetless::prepare;
using targetless::rigid;
using SurfacePtr = std::shared_ptr<const icp::Surface>;

std::string cam(size_t i) {
  return "camera " + std::to_string(i);
}
std::string format_fixed(double v, int digits) {
  return fmt::format("{:.{}f}", v, digits);
}

Eigen::Matrix4d matrix(const RigidTransform& t) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = t.rotation;
  m.topRightCorner<3, 1>() = t.translation;
  return m;
}

// The finest level: measured samples themselves (every k-th, at most ~60000), not voxel centroids,
// which pull surfaces inward at edges by up to half a voxel and so bias the poses.
Cloud prepare_fine(const std::vector<Eigen::Vector3d>& points, double radius_m) {
  o3g::PointCloud raw(points);
  const size_t every = std::max<size_t>(1, points.size() / 60000);
  Cloud down = raw.UniformDownSample(every);
  down->EstimateNormals(o3g::KDTreeSearchParamHybrid(radius_m, 30));
  down->OrientNormalsTowardsCameraLocation(Eigen::Vector3d::Zero());
  return down;
}

SurfacePtr surface(const o3g::PointCloud& cloud) {
  return std::make_shared<const icp::Surface>(cloud.points_, cloud.normals_);
}

// One cloud at every ICP level, with normals and its k-d tree (levels 0..2: voxel centroids;
// 3: samples).
constexpr int kLevels = 4;
struct Levels {
  SurfacePtr level[kLevels];
};

Levels prepare_levels(const std::vector<Eigen::Vector3d>& points, const TargetlessOptions& o) {
  return {{surface(*prepare(points, o.icp_voxels_m[0])),
           surface(*prepare(points, o.icp_voxels_m[1])),
           surface(*prepare(points, o.icp_voxels_m[2])),
           surface(*prepare_fine(points, 3 * o.icp_voxels_m[2]))}};
}

// `surface` placed in a target frame by target_from_surface (a query's partner).
icp::Placed placed(const SurfacePtr& surface, const RigidTransform& target_from_surface) {
  return {surface.get(), target_from_surface.rotation, target_from_surface.translation};
}

// What ICP aligns to, per level: one camera's surface (in its frame), or all other cameras'
// placed in the world.
using Target = std::array<std::vector<icp::Placed>, kLevels>;

Target alone(const Levels& levels) {
  Target t;
  for (int l = 0; l < kLevels; ++l) t[static_cast<size_t>(l)] = {placed(levels.level[l], {})};
  return t;
}

struct PairFit {
  RigidTransform target_from_source;
  double fitness = 0;  // share of the source's points with a partner
  double rms_m = 0;
};

// Coarse-to-fine point-to-plane ICP with a Tukey loss from `start`, over levels `first`..`last`
// (2: the coarse ones, for checking hypotheses; 3: down to the samples). Fitness and RMS at the
// last level run, within the overlap distance.
PairFit icp(const Levels& source, const Target& target, const RigidTransform& start,
            const TargetlessOptions& o, int first, int last, WorkerPool& pool) {
  Eigen::Matrix4d t = matrix(start);
  for (int level = first; level <= last; ++level) {
    const double voxel = o.icp_voxels_m[level];
    icp::Criteria criteria;
    criteria.max_iterations = level < 2 ? 60 : 30;
    t = icp::point_to_plane(source.level[level]->points(), target[static_cast<size_t>(level)],
                            voxel * 2.0, t, voxel, criteria, &pool)
            .target_from_source;
  }
  const icp::Fit eval =
      icp::evaluate(source.level[last]->points(), target[static_cast<size_t>(last)],
                    std::max(o.overlap_distance_m, o.icp_voxels_m[last]), t, &pool);
  PairFit fit;
  fit.target_from_source = rigid(t);
  fit.fitness = eval.fitness;
  fit.rms_m = eval.inlier_rms_m;
  return fit;
}

// Share of `source`'s points (in its camera frame, placed in the target camera's frame by
// target_from_source) that the target camera would have seen in front of what it measured: it
// looked through where they are, so the hypothesis is wrong (free-space violation).
double free_space_violations(const std::vector<Eigen::Vector3d>& source_points,
                             const RigidTransform& target_from_source, const DepthImage& depth,
                             const Intrinsics& k, double margin_m) {
  int checked = 0, violated = 0;
  for (const Eigen::Vector3d& q : source_points) {
    const Eigen::Vector3d p = target_from_source * q;
    if (p.z() < 0.2) continue;
    const auto uv = project_normalized(k, Eigen::Vector2d(p.x() / p.z(), p.y() / p.z()));
    if (!uv) continue;
    const long u = std::lround(uv->x()), v = std::lround(uv->y());
    if (u < 0 || v < 0 || u >= depth.width || v >= depth.height) continue;
    const uint16_t measured = depth.at(static_cast<int>(u), static_cast<int>(v));
    if (measured == 0) continue;
    ++checked;
    if (p.z() < measured * 1e-3 - margin_m) ++violated;
  }
  return checked ? static_cast<double>(violated) / checked : 0.0;
}

// The smallest / largest eigenvalue of sum n n^T over the overlap's partner normals (the
// translation block of point-to-plane ICP's normal equations): near 0 when the overlap leaves a
// direction free (one plane: two directions; two planes: their common line).
double translation_conditioning(const Eigen::Matrix3d& normals) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(normals);
  const Eigen::Vector3d ev = eig.eigenvalues();
  return ev(2) > 0 ? std::max(0.0, ev(0)) / ev(2) : 0.0;
}

// Each placed camera's overlap with the other placed cameras at world_from_camera, from its
// samples with normals (prepare_fine, camera frame); an unplaced camera (nullopt) gets an empty
// CameraOverlap and is no one's partner.
std::vector<CameraOverlap> overlap(std::span<const SurfacePtr> samples,
                                   std::span<const std::optional<RigidTransform>> world_from_camera,
                                   double overlap_distance_m) {
  const size_t n_cameras = samples.size();
  std::vector<CameraOverlap> out(n_cameras);
  const double max_d2 = overlap_distance_m * overlap_distance_m;
  for (size_t c = 0; c < n_cameras; ++c) {
    if (!world_from_camera[c] || !samples[c] || samples[c]->points().empty()) continue;
    std::vector<icp::Placed> others;  // in the world
    for (size_t d = 0; d < n_cameras; ++d)
      if (d != c && world_from_camera[d] && samples[d] && !samples[d]->points().empty())
        others.push_back(placed(samples[d], *world_from_camera[d]));
    if (others.empty()) continue;
    const RigidTransform& world_from_c = *world_from_camera[c];
    double sum = 0;
    int n = 0;
    Eigen::Matrix3d normals = Eigen::Matrix3d::Zero();
    icp::Neighbour partner;
    for (const Eigen::Vector3d& q : samples[c]->points()) {
      const Eigen::Vector3d p = world_from_c * q;
      if (!icp::nearest(others, p, max_d2, partner)) continue;
      const Eigen::Vector3d& normal = partner.normal;
      const double r = (p - partner.point).dot(normal);
      sum += r * r;
      normals += normal * normal.transpose();
      ++n;
    }
    out[c].conditioning = translation_conditioning(normals);
    out[c].points = n;
    out[c].fraction = static_cast<double>(n) / static_cast<double>(samples[c]->points().size());
    out[c].rms_m = n ? std::sqrt(sum / n) : 0;
  }
  return out;
}

}  // namespace

std::vector<Eigen::Vector3d> depth_points(const DepthImage& depth, const RayTable& rays, int stride,
                                          double min_m, double max_m) {
  if (depth.width != rays.width || depth.height != rays.height)
    throw Error("depth_points: depth is " + std::to_string(depth.width) + "x" +
                std::to_string(depth.height) + " but the ray table is " +
                std::to_string(rays.width) + "x" + std::to_string(rays.height));
  stride = std::max(stride, 1);
  std::vector<Eigen::Vector3d> out;
  out.reserve(depth.size() / (static_cast<size_t>(stride) * stride));
  for (int y = 0; y < depth.height; y += stride)
    for (int x = 0; x < depth.width; x += stride) {
      const size_t i = static_cast<size_t>(y) * depth.width + x;
      const double z = depth.pixels[i] * 1e-3;
      if (z < min_m || z > max_m || !std::isfinite(rays.x[i]) || !std::isfinite(rays.y[i]))
        continue;
      out.emplace_back(rays.x[i] * z, rays.y[i] * z, z);
    }
  return out;
}

std::vector<CameraOverlap> measure_overlap(std::span<const std::vector<Eigen::Vector3d>> clouds,
                                           std::span<const RigidTransform> world_from_camera,
                                           double voxel_m, double overlap_distance_m) {
  const std::vector<std::optional<RigidTransform>> placed(world_from_camera.begin(),
                                                          world_from_camera.end());
  return measure_overlap(clouds, placed, voxel_m, overlap_distance_m);
}

std::vector<CameraOverlap> measure_overlap(
    std::span<const std::vector<Eigen::Vector3d>> clouds,
    std::span<const std::optional<RigidTransform>> world_from_camera, double voxel_m,
    double overlap_distance_m) {
  if (clouds.size() != world_from_camera.size())
    throw Error("measure_overlap: " + std::to_string(clouds.size()) + " clouds but " +
                std::to_string(world_from_camera.size()) + " poses");
  std::vector<SurfacePtr> samples(clouds.size());
  for (size_t c = 0; c < clouds.size(); ++c)
    if (world_from_camera[c]) samples[c] = surface(*prepare_fine(clouds[c], 3 * voxel_m));
  return overlap(samples, world_from_camera, overlap_distance_m);
}

namespace {

// What register_targetless works on: the cameras, their starts, the options, where progress
// goes, and per camera (camera frame, metres) a sparse copy of its cloud (the free-space check),
// its ICP levels, its samples with normals for measuring the overlap, and its features (computed
// when a pair it is in first needs them).
struct Work {
  std::span<const TargetlessCamera> cameras;
  std::span<const std::optional<RigidTransform>> start;
  const TargetlessOptions& o;
  std::function<void(const std::string&)> note;
  WorkerPool& pool;  // the ICP's passes over the points
  std::vector<std::vector<Eigen::Vector3d>> sparse;
  std::vector<Levels> levels;
  std::vector<SurfacePtr> samples;
  std::vector<std::optional<Features>> features;

  bool usable(size_t c) const { return cameras[c].cloud.size() >= 100; }
  const Features& features_of(size_t c) {
    if (!features[c]) features[c] = compute_features(cameras[c].cloud, o);
    return *features[c];
  }
};

// Whether `world_from_c` ends within the tolerance of the camera's start (always, without one).
bool near_start(const std::optional<RigidTransform>& start, const RigidTransform& world_from_c,
                const TargetlessOptions& o) {
  if (!start) return true;
  const double angle =
      Eigen::AngleAxisd(start->rotation.transpose() * world_from_c.rotation).angle();
  return (world_from_c.translation - start->translation).norm() <= o.start_tolerance_m &&
         angle <= o.start_tolerance_deg * M_PI / 180;
}

// The best alignment of camera c to placed camera p found so far (score: overlap, -1 none).
struct Tried {
  bool done = false;
  double score = -1;
  RigidTransform p_from_c;
};

// How far the 3 cm level moved a hypothesis past where the coarse levels left it, on the real
// four-camera room (issue 51): at most 9 cm and 1.6 deg, and the free-space share by at most 1.5
// points. A coarse result farther than these margins beyond a limit is rejected without it.
constexpr double kFineMoveMarginM = 0.25;
constexpr double kFineMoveMarginDeg = 5.0;
// Coarse results this close (metres, degrees) start the 3 cm level at the same place: it is run
// once for them (RANSAC's hypotheses often agree with the start or with each other).
constexpr double kSameCoarseM = 0.002;
constexpr double kSameCoarseDeg = 0.1;

double angle_deg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return Eigen::AngleAxisd(a.transpose() * b).angle() * 180 / M_PI;
}

// Camera c against placed camera p: each hypothesis (its start, then the features') refined by
// ICP, kept when it agrees with what both saw (free space) and stays near c's start; the best
// into `t`. The coarse levels run for every hypothesis; the 3 cm level (most of the cost) only for
// those that could still be kept and do not repeat an earlier one's coarse result.
void try_pair(Work& w, size_t c, size_t p, const std::vector<std::optional<RigidTransform>>& pose,
              Tried& t) {
  const TargetlessOptions& o = w.o;
  std::vector<RigidTransform> hypotheses;
  if (w.start[c]) hypotheses.push_back(pose[p]->inverse() * *w.start[c]);
  const size_t from_start = hypotheses.size();
  const Features& fc = w.features_of(c);
  for (const RigidTransform& g : global_candidates(fc, w.features_of(p), o, w.pool))
    hypotheses.push_back(g);
  const auto violations_at = [&](const RigidTransform& p_from_c) {
    return std::max(free_space_violations(w.sparse[c], p_from_c, w.cameras[p].depth,
                                          w.cameras[p].intrinsics, o.free_space_margin_m),
                    free_space_violations(w.sparse[p], p_from_c.inverse(), w.cameras[c].depth,
                                          w.cameras[c].intrinsics, o.free_space_margin_m));
  };
  struct Refined {
    RigidTransform coarse;
    PairFit fit;
    double violations;
  };
  std::vector<Refined> refined;
  const Target to_p = alone(w.levels[p]);
  for (size_t h = 0; h < hypotheses.size(); ++h) {
    const bool is_start = h < from_start;
    const std::string what = cam(c) + " against " + cam(p) +
                             (is_start ? ": its start" : ": features + RANSAC") + ", then ICP";
    const PairFit coarse = icp(w.levels[c], to_p, hypotheses[h], o, is_start ? 0 : 1, 1, w.pool);
    const RigidTransform& g = coarse.target_from_source;
    const RigidTransform world_from_c = *pose[p] * g;
    if (w.start[c]) {
      const double off_m = (world_from_c.translation - w.start[c]->translation).norm();
      const double off_deg = angle_deg(w.start[c]->rotation, world_from_c.rotation);
      if (off_m > o.start_tolerance_m + kFineMoveMarginM ||
          off_deg > o.start_tolerance_deg + kFineMoveMarginDeg) {
        w.note(what + " to " + format_fixed(o.icp_voxels_m[1] * 100, 0) +
               " cm: " + format_fixed(off_m, 2) + " m / " + format_fixed(off_deg, 0) +
               " deg from its start (rejected: too far from its start)");
        continue;
      }
    }
    const double coarse_violations = violations_at(g);
    if (coarse_violations > 2 * o.max_free_space_violations) {
      w.note(what + " to " + format_fixed(o.icp_voxels_m[1] * 100, 0) + " cm: " +
             format_fixed(coarse_violations * 100, 1) + "% in the other's free space (rejected)");
      continue;
    }
    const auto earlier = std::find_if(refined.begin(), refined.end(), [&](const Refined& r) {
      return (r.coarse.translation - g.translation).norm() <= kSameCoarseM &&
             angle_deg(r.coarse.rotation, g.rotation) <= kSameCoarseDeg;
    });
    const bool repeated = earlier != refined.end();
    if (!repeated) {
      const PairFit fine = icp(w.levels[c], to_p, g, o, 2, 2, w.pool);
      refined.push_back({g, fine, violations_at(fine.target_from_source)});
    }
    const Refined& r = repeated ? *earlier : refined.back();
    const bool near = near_start(w.start[c], *pose[p] * r.fit.target_from_source, o);
    const bool ok = r.violations <= o.max_free_space_violations && near;
    w.note(what + ": " + format_fixed(r.fit.fitness * 100, 1) + "% overlap, RMS " +
           format_fixed(r.fit.rms_m * 1e3, 1) + " mm, " + format_fixed(r.violations * 100, 1) +
           "% in the other's free space" + (repeated ? " (as an earlier hypothesis)" : "") +
           (ok     ? ""
            : near ? " (rejected)"
                   : " (rejected: too far from its start)"));
    if (ok && r.fit.fitness > t.score) {
      t.score = r.fit.fitness;
      t.p_from_c = r.fit.target_from_source;
    }
  }
}

// 1. Placement: started cameras where they are; the others by features, one at a time, each
//    against the placed camera it matches best. A hypothesis must agree with what both cameras
//    saw: neither may see the other's points in its free space. Only the reference is placed as
//    given. A camera with a start is placed like the others, from hypotheses (its start, and the
//    features') refined and checked against the cameras already placed -- keeping those that end
//    within the tolerance of its start -- so one rough start cannot pull the others.
std::vector<std::optional<RigidTransform>> place_cameras(Work& w, size_t ref) {
  const size_t n = w.cameras.size();
  const TargetlessOptions& o = w.o;
  std::vector<std::optional<RigidTransform>> pose(n);
  pose[ref] = w.start[ref].value_or(RigidTransform{});
  std::vector<std::vector<Tried>> tried(n, std::vector<Tried>(n));
  for (;;) {
    double best_score = -1;
    size_t best = n;
    RigidTransform best_pose;
    for (size_t c = 0; c < n; ++c) {
      if (pose[c] || !w.usable(c)) continue;
      for (size_t p = 0; p < n; ++p) {
        if (!pose[p] || !w.usable(p)) continue;
        Tried& t = tried[c][p];
        if (!t.done) {
          t.done = true;
          try_pair(w, c, p, pose, t);
        }
        if (t.score > best_score) {
          best_score = t.score;
          best = c;
          best_pose = *pose[p] * t.p_from_c;
        }
      }
    }
    if (best == n || best_score < o.min_overlap) break;
    pose[best] = best_pose;
  }
  return pose;
}

// 2. Joint refinement: each camera in turn, ICP against all the other placed cameras together
//    (the reference stays), a few rounds -- every overlap pulls at once, no chain of pairs.
void refine_jointly(const Work& w, size_t ref, std::vector<std::optional<RigidTransform>>& pose) {
  const size_t n = w.cameras.size();
  const TargetlessOptions& o = w.o;
  for (int round = 0; round < o.joint_rounds; ++round)
    for (size_t c = 0; c < n; ++c) {
      if (!pose[c] || c == ref) continue;
      // From the coarsest level in the first round (a start may be 20 cm off), down to the
      // samples in the last; the others at those levels only.
      const int first = round == 0 ? 0 : 1, last = round + 1 < o.joint_rounds ? 2 : 3;
      // Merged per level: ICP's many passes then search one tree, not one per camera.
      Target others;  // in the world
      std::array<SurfacePtr, kLevels> merged;
      for (size_t l = static_cast<size_t>(first); l <= static_cast<size_t>(last); ++l) {
        std::vector<icp::Placed> parts;
        for (size_t d = 0; d < n; ++d)
          if (d != c && pose[d]) parts.push_back(placed(w.levels[d].level[l], *pose[d]));
        merged[l] = icp::merged(parts);
        others[l] = {placed(merged[l], {})};
      }
      const PairFit f = icp(w.levels[c], others, *pose[c], o, first, last, w.pool);
      pose[c] = f.target_from_source;
      if (round == o.joint_rounds - 1)
        w.note(cam(c) + " against all others: ICP " + format_fixed(f.fitness * 100, 1) +
               "% overlap, RMS " + format_fixed(f.rms_m * 1e3, 1) + " mm");
    }
}

// 3. Verify: every placed camera must overlap and be constrained; otherwise say so, no pose.
void verify(const Work& w, size_t ref, const std::vector<std::optional<RigidTransform>>& pose,
            TargetlessResult& result) {
  const size_t n = w.cameras.size();
  const TargetlessOptions& o = w.o;
  result.after = overlap(w.samples, pose, o.overlap_distance_m);
  for (size_t c = 0; c < n; ++c) {
    if (!pose[c]) continue;
    result.conditioning[c] = result.after[c].conditioning;
    if (c == ref) {  // the anchor: its pose is the world's definition, not a measurement
      result.world_from_camera[c] = pose[c];
      continue;
    }
    if (n > 1 && result.after[c].fraction < o.min_overlap) {
      result.problems.push_back(cam(c) + ": only " +
                                format_fixed(result.after[c].fraction * 100, 1) +
                                "% of it overlaps the other cameras after registration (needs " +
                                format_fixed(o.min_overlap * 100, 0) + "%); its pose is not known");
      continue;
    }
    if (n > 1 && result.conditioning[c] < o.min_conditioning) {
      result.problems.push_back(
          cam(c) +
          ": what it shares with the other cameras is (nearly) one plane or one "
          "direction (conditioning " +
          format_fixed(result.conditioning[c], 4) +
          "), so it can slide along it; its pose is not known -- add shape to the overlap (a box, "
          "a chair) or use the target");
      continue;
    }
    result.world_from_camera[c] = pose[c];
  }
}

}  // namespace

TargetlessResult register_targetless(std::span<const TargetlessCamera> cameras,
                                     std::span<const std::optional<RigidTransform>> start,
                                     int reference, const TargetlessOptions& o) {
  const size_t n = cameras.size();
  if (start.size() != n)
    throw Error("register_targetless: " + std::to_string(n) + " cameras but " +
                std::to_string(start.size()) + " start poses");
  if (reference < 0 || static_cast<size_t>(reference) >= n)
    throw Error("register_targetless: reference camera " + std::to_string(reference) +
                " is not one of the " + std::to_string(n) + " cameras");
  open3d::utility::SetVerbosityLevel(open3d::utility::VerbosityLevel::Error);
  open3d::utility::random::Seed(static_cast<int>(o.seed));
  TargetlessResult result;
  WorkerPool pool;
  Work w{cameras,
         start,
         o,
         [&](const std::string& line) {
           result.log.push_back(line);
           if (o.progress) o.progress(line);
         },
         pool,
         std::vector<std::vector<Eigen::Vector3d>>(n),
         std::vector<Levels>(n),
         std::vector<SurfacePtr>(n),
         std::vector<std::optional<Features>>(n)};
  result.world_from_camera.assign(n, std::nullopt);
  result.conditioning.assign(n, 0);
  const size_t ref = static_cast<size_t>(reference);
  for (size_t c = 0; c < n; ++c)
    if (!w.usable(c)) result.problems.push_back(cam(c) + ": fewer than 100 valid depth samples");

  // Each camera's clouds once: the overlap is measured three times (at the start, after
  // placement, at the result) and the ICP levels serve every pair and round.
  for (size_t c = 0; c < n; ++c) {
    const std::vector<Eigen::Vector3d>& cloud = cameras[c].cloud;
    w.samples[c] = surface(*prepare_fine(cloud, 3 * o.icp_voxels_m[3]));
    w.sparse[c] = o3g::PointCloud(cloud).VoxelDownSample(0.05)->points_;
    if (w.usable(c)) w.levels[c] = prepare_levels(cloud, o);
  }
  if (std::all_of(start.begin(), start.end(), [](const auto& s) { return s.has_value(); }))
    result.before = overlap(w.samples, start, o.overlap_distance_m);

  std::vector<std::optional<RigidTransform>> pose = place_cameras(w, ref);
  for (size_t c = 0; c < n; ++c)
    if (!pose[c] && w.usable(c))
      result.problems.push_back(
          cam(c) +
          (start[c]
               ? ": no alignment to the other cameras found near its start or from features (it "
               : ": no alignment to the other cameras found from features (it ") +
          "shares too little of the scene with them, or the scene has too "
          "little shape); give it a rough start (viewer sliders) or a target");

  const auto started = overlap(w.samples, pose, o.overlap_distance_m);
  for (size_t c = 0; c < n; ++c)
    if (pose[c])
      w.note(cam(c) + " before the joint ICP: overlap " +
             format_fixed(started[c].fraction * 100, 1) + "%, RMS " +
             format_fixed(started[c].rms_m * 1e3, 1) + " mm");
  refine_jointly(w, ref, pose);
  verify(w, ref, pose, result);
  return result;
}

}  // namespace volcast
