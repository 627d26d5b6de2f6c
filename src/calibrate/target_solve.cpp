// Every camera's world_from_camera from its observations of the target's placements ("captures"):
// a first guess along a spanning tree of shared captures (one observation's Kabsch each), then
// alternating closed-form least squares: with the cameras fixed, each capture's world_from_target
// from all its centres in the world; with the captures fixed, each camera's world_from_camera from
// all its centres. Each step lowers the same sum of squares, so it converges.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "volcast/calibrate/target.hpp"
#include "volcast/core/error.hpp"

namespace volcast {
namespace {

// The rigid a_from_b that best maps the points `b` onto `a` (Umeyama without scale), both 3xN.
RigidTransform kabsch(const Eigen::Matrix3Xd& a, const Eigen::Matrix3Xd& b) {
  const Eigen::Matrix4d m = Eigen::umeyama(b, a, false);
  return {m.topLeftCorner<3, 3>(), m.topRightCorner<3, 1>()};
}

// How far `t` moves points within 1 m of the origin from where `before` put them, metres (a bound).
double moved(const RigidTransform& before, const RigidTransform& t) {
  return (t.translation - before.translation).norm() + (t.rotation - before.rotation).norm();
}

// Throws Error for counts below 0, a reference camera out of range or an observation naming a
// camera, capture or sphere that is not there.
void check_inputs(int cameras, int captures, std::span<const TargetObservation> observations,
                  int reference_camera, const TargetModel& model) {
  if (cameras < 0 || captures < 0)
    throw Error("solve_target_registration: negative camera or capture count");
  if (reference_camera >= cameras)
    throw Error("solve_target_registration: reference camera " + std::to_string(reference_camera) +
                " is not one of the " + std::to_string(cameras) + " cameras");
  for (const TargetObservation& o : observations) {
    if (o.camera < 0 || o.camera >= cameras)
      throw Error("solve_target_registration: an observation of camera " +
                  std::to_string(o.camera) + ", but there are " + std::to_string(cameras) +
                  " cameras");
    if (o.capture < 0 || o.capture >= captures)
      throw Error("solve_target_registration: an observation of capture " +
                  std::to_string(o.capture) + ", but there are " + std::to_string(captures) +
                  " captures");
    for (const auto& [j, x] : o.centres)
      if (j < 0 || static_cast<size_t>(j) >= model.centres_m.size() || !x.allFinite())
        throw Error("solve_target_registration: camera " + std::to_string(o.camera) + ", capture " +
                    std::to_string(o.capture) + ": sphere " + std::to_string(j) +
                    " is not one of the model's " + std::to_string(model.centres_m.size()) +
                    " (or its centre is not finite)");
  }
}

// Observations usable for a pose (>= 3 centres; detect_target gives no fewer); `seen[i]` gets
// observation i's own camera_from_target.
std::vector<size_t> usable_observations(std::span<const TargetObservation> observations,
                                        const TargetModel& model,
                                        std::vector<RigidTransform>& seen) {
  const auto model_point = [&](int j) { return model.centres_m[static_cast<size_t>(j)]; };
  std::vector<size_t> usable;
  for (size_t i = 0; i < observations.size(); ++i) {
    const auto& centres = observations[i].centres;
    if (centres.size() < 3) continue;
    Eigen::Matrix3Xd a(3, static_cast<long>(centres.size())), b(3, a.cols());
    for (size_t n = 0; n < centres.size(); ++n) {
      a.col(static_cast<long>(n)) = centres[n].second;
      b.col(static_cast<long>(n)) = model_point(centres[n].first);
    }
    seen[i] = kabsch(a, b);
    usable.push_back(i);
  }
  return usable;
}

// Without a reference camera, the world is a capture's target placement: the lowest capture of
// the group of cameras and captures (joined by observations) that holds the most cameras, ties to
// the lowest capture, so a stray detection cannot take the world away; -1 when none is usable.
int root_capture_of(size_t nc, size_t nk, std::span<const TargetObservation> observations,
                    const std::vector<size_t>& usable) {
  int root_capture = -1;
  std::vector<size_t> parent(nc + nk);  // union-find over cameras 0..nc-1, captures nc..
  for (size_t i = 0; i < parent.size(); ++i) parent[i] = i;
  const auto find = [&](size_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  for (const size_t i : usable)
    parent[find(static_cast<size_t>(observations[i].camera))] =
        find(nc + static_cast<size_t>(observations[i].capture));
  std::vector<int> cameras_in(parent.size(), 0);
  for (size_t c = 0; c < nc; ++c) ++cameras_in[find(c)];
  for (const size_t i : usable) {
    const int k = observations[i].capture;
    if (root_capture < 0) {
      root_capture = k;
      continue;
    }
    const int here = cameras_in[find(nc + static_cast<size_t>(k))];
    const int best = cameras_in[find(nc + static_cast<size_t>(root_capture))];
    if (here > best || (here == best && k < root_capture)) root_capture = k;
  }
  return root_capture;
}

// The spanning tree of shared captures from the world: places every camera and capture that a
// chain of usable observations joins to one already placed.
void grow_from_world(std::span<const TargetObservation> observations,
                     const std::vector<size_t>& usable, const std::vector<RigidTransform>& seen,
                     TargetSolution& s) {
  for (bool grew = true; grew;) {
    grew = false;
    for (const size_t i : usable) {
      auto& cam = s.world_from_camera[static_cast<size_t>(observations[i].camera)];
      auto& tgt = s.world_from_target[static_cast<size_t>(observations[i].capture)];
      if (cam && !tgt) {
        tgt = *cam * seen[i];
        grew = true;
      } else if (tgt && !cam) {
        cam = *tgt * seen[i].inverse();
        grew = true;
      }
    }
  }
}

// Alternating least squares over the placed cameras and captures until no pose moves by 1e-9 m
// (200 rounds at most); the world's own frame (reference camera or root capture) stays.
void refine_poses(std::span<const TargetObservation> observations,
                  const std::vector<size_t>& usable, const TargetModel& model, int reference_camera,
                  int root_capture, TargetSolution& s) {
  const size_t nc = s.world_from_camera.size(), nk = s.world_from_target.size();
  const auto model_point = [&](int j) { return model.centres_m[static_cast<size_t>(j)]; };
  Eigen::Matrix3Xd a, b;
  const auto gather = [&](auto&& take) {  // take(observation) -> add its pairs; returns the count
    long count = 0;
    for (const size_t i : usable) count += take(observations[i], nullptr, nullptr, 0);
    a.resize(3, count);
    b.resize(3, count);
    long col = 0;
    for (const size_t i : usable) col += take(observations[i], &a, &b, col);
    return count;
  };
  for (int iteration = 0; iteration < 200; ++iteration) {
    double change = 0;
    for (size_t k = 0; k < nk; ++k) {  // each capture from every placed camera that saw it
      if (!s.world_from_target[k] || static_cast<int>(k) == root_capture) continue;
      const long n = gather([&](const TargetObservation& o, Eigen::Matrix3Xd* pa,
                                Eigen::Matrix3Xd* pb, long col) -> long {
        const auto& cam = s.world_from_camera[static_cast<size_t>(o.camera)];
        if (static_cast<size_t>(o.capture) != k || !cam) return 0;
        if (pa)
          for (const auto& [j, x] : o.centres) {
            pa->col(col) = *cam * x;
            pb->col(col++) = model_point(j);
          }
        return static_cast<long>(o.centres.size());
      });
      if (n < 3) continue;
      const RigidTransform t = kabsch(a, b);
      change = std::max(change, moved(*s.world_from_target[k], t));
      s.world_from_target[k] = t;
    }
    for (size_t c = 0; c < nc; ++c) {  // each camera from every placed capture it saw
      if (!s.world_from_camera[c] || static_cast<int>(c) == reference_camera) continue;
      const long n = gather([&](const TargetObservation& o, Eigen::Matrix3Xd* pa,
                                Eigen::Matrix3Xd* pb, long col) -> long {
        const auto& tgt = s.world_from_target[static_cast<size_t>(o.capture)];
        if (static_cast<size_t>(o.camera) != c || !tgt) return 0;
        if (pa)
          for (const auto& [j, x] : o.centres) {
            pa->col(col) = *tgt * model_point(j);
            pb->col(col++) = x;
          }
        return static_cast<long>(o.centres.size());
      });
      if (n < 3) continue;
      const RigidTransform t = kabsch(a, b);
      change = std::max(change, moved(*s.world_from_camera[c], t));
      s.world_from_camera[c] = t;
    }
    if (change < 1e-9) break;
  }
}

// Residuals (rms_m, features) per camera, and why each unplaced camera is unplaced.
void add_residuals(std::span<const TargetObservation> observations,
                   const std::vector<size_t>& usable, const TargetModel& model, TargetSolution& s) {
  const size_t nc = s.world_from_camera.size();
  const auto model_point = [&](int j) { return model.centres_m[static_cast<size_t>(j)]; };
  std::vector<double> sum(nc, 0);
  for (const size_t i : usable) {
    const TargetObservation& o = observations[i];
    const size_t c = static_cast<size_t>(o.camera), k = static_cast<size_t>(o.capture);
    if (!s.world_from_camera[c] || !s.world_from_target[k]) continue;
    for (const auto& [j, x] : o.centres) {
      sum[c] +=
          (*s.world_from_camera[c] * x - *s.world_from_target[k] * model_point(j)).squaredNorm();
      ++s.features[c];
    }
  }
  for (size_t c = 0; c < nc; ++c) {
    if (s.features[c] > 0) s.rms_m[c] = std::sqrt(sum[c] / s.features[c]);
    if (s.world_from_camera[c]) continue;
    bool saw = false, any = false;
    for (const TargetObservation& o : observations)
      if (static_cast<size_t>(o.camera) == c) {
        any = true;
        saw = saw || o.centres.size() >= 3;
      }
    std::string why = !any   ? "never saw the target"
                      : !saw ? "saw fewer than 3 of the target's spheres in every capture"
                             : "saw the target only in captures no other placed camera saw";
    s.problems.push_back("camera " + std::to_string(c) + ": " + why);
  }
}

}  // namespace

TargetSolution solve_target_registration(int cameras, int captures,
                                         std::span<const TargetObservation> observations,
                                         int reference_camera, const TargetModel& model) {
  check_inputs(cameras, captures, observations, reference_camera, model);
  const size_t nc = static_cast<size_t>(cameras), nk = static_cast<size_t>(captures);
  TargetSolution s;
  s.world_from_camera.assign(nc, std::nullopt);
  s.world_from_target.assign(nk, std::nullopt);
  s.rms_m.assign(nc, 0);
  s.features.assign(nc, 0);
  std::vector<RigidTransform> seen(observations.size());
  const std::vector<size_t> usable = usable_observations(observations, model, seen);
  int root_capture = -1;
  if (reference_camera >= 0) {
    s.world_from_camera[static_cast<size_t>(reference_camera)] = RigidTransform{};
  } else {
    root_capture = root_capture_of(nc, nk, observations, usable);
    if (root_capture >= 0)
      s.world_from_target[static_cast<size_t>(root_capture)] = RigidTransform{};
  }
  grow_from_world(observations, usable, seen, s);
  refine_poses(observations, usable, model, reference_camera, root_capture, s);
  add_residuals(observations, usable, model, s);
  return s;
}

}  // namespace volcast
