// The synthetic depth camera (SYNTHETIC data for tests and benchmarks): per pixel, the ray of the
// real lens model (make_ray_table) against the target's spheres, its rods (finite cylinders), extra
// balls and the floor; nearest hit; then Azure Kinect-like noise, flying pixels at depth edges,
// dropout and grazing-angle loss, deterministic for a seed. The scene's parts are placed in the
// world once per image and each 16 x 16 tile of pixels tests only the parts its rays can reach.
#include "volcast/calibrate/target_sim.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>

#include "volcast/core/error.hpp"
#include "volcast/core/ray_table.hpp"

namespace volcast {
namespace {

struct Hit {
  double t = 1e9;  // along the unit ray, metres
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
};

void sphere(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Eigen::Vector3d& c, double r,
            Hit& hit) {
  const Eigen::Vector3d oc = o - c;
  const double b = oc.dot(d), disc = b * b - (oc.squaredNorm() - r * r);
  if (disc < 0) return;
  const double t = -b - std::sqrt(disc);
  if (t > 1e-4 && t < hit.t) hit = {t, (o + d * t - c).normalized()};
}

// A rod of the target in the world frame: from `a` along the unit `axis` for `length` metres.
struct Rod {
  Eigen::Vector3d a, axis;
  double length = 0;
};

void cylinder(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Rod& rod, double r,
              Hit& hit) {
  const Eigen::Vector3d& a = rod.a;
  const Eigen::Vector3d& axis = rod.axis;
  const Eigen::Vector3d dp = d - axis * d.dot(axis), op = (o - a) - axis * (o - a).dot(axis);
  const double qa = dp.squaredNorm(), qb = 2 * dp.dot(op), qc = op.squaredNorm() - r * r;
  const double disc = qb * qb - 4 * qa * qc;
  if (qa < 1e-12 || disc < 0) return;
  const double t = (-qb - std::sqrt(disc)) / (2 * qa);
  if (t <= 1e-4 || t >= hit.t) return;
  const Eigen::Vector3d p = o + d * t;
  const double s = (p - a).dot(axis);
  if (s < 0 || s > rod.length) return;
  hit = {t, (p - a - axis * s).normalized()};
}

// A part of the scene that rays are tested against (a target sphere, a rod, an extra ball) in the
// world frame, with a ball holding it: a ray that misses the ball misses the part.
struct Part {
  enum class Kind { kSphere, kRod } kind = Kind::kSphere;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();  // the sphere's centre, or the rod's middle
  double radius = 0;                                 // the sphere's, or the rod's
  Rod rod;
  double bound = 0;  // radius of the ball about `centre` holding the part
};

std::vector<Part> place(const SimScene& scene) {
  std::vector<Part> parts;
  const TargetModel& m = scene.target;
  for (const auto& c : m.centres_m) {
    const Eigen::Vector3d w = scene.world_from_target * c;
    parts.push_back({Part::Kind::kSphere, w, m.sphere_radius_m, {}, m.sphere_radius_m});
  }
  for (const auto& [a, b] : m.rods_m) {
    const Eigen::Vector3d wa = scene.world_from_target * a, wb = scene.world_from_target * b;
    const Rod rod{wa, (wb - wa).normalized(), (wb - wa).norm()};
    parts.push_back(
        {Part::Kind::kRod, (wa + wb) / 2, m.rod_radius_m, rod, rod.length / 2 + m.rod_radius_m});
  }
  for (const auto& [c, r] : scene.extra_spheres)
    parts.push_back({Part::Kind::kSphere, c, r, {}, r});
  return parts;
}

// The pixels are rendered in square tiles: each tile's rays lie in a cone about its mean ray, and
// only the parts whose ball meets that cone are tested for its pixels (exact: a part outside the
// cone cannot be hit by any of the tile's rays).
constexpr int kTile = 16;

// The parts (indices into `parts`) whose ball meets the cone from `o` holding the unit `dirs`.
void parts_in_cone(const Eigen::Vector3d& o, const std::vector<Eigen::Vector3d>& dirs,
                   const std::vector<Part>& parts, std::vector<int>& out) {
  out.clear();
  if (dirs.empty()) return;
  Eigen::Vector3d axis = Eigen::Vector3d::Zero();
  for (const auto& d : dirs) axis += d;
  axis.normalize();
  double half = 0;  // the cone's half angle, radians
  for (const auto& d : dirs) half = std::max(half, std::acos(std::clamp(axis.dot(d), -1.0, 1.0)));
  for (size_t p = 0; p < parts.size(); ++p) {
    const Eigen::Vector3d v = parts[p].centre - o;
    const double dist = v.norm();
    if (dist <= parts[p].bound) {  // the camera is inside the ball: any ray may hit it
      out.push_back(static_cast<int>(p));
      continue;
    }
    const double to_centre = std::acos(std::clamp(axis.dot(v) / dist, -1.0, 1.0));
    const double ball = std::asin(parts[p].bound / dist);
    if (to_centre - ball <= half + 1e-9) out.push_back(static_cast<int>(p));
  }
}

}  // namespace

RigidTransform camera_looking_at(const Eigen::Vector3d& eye, const Eigen::Vector3d& at,
                                 double roll_deg) {
  const Eigen::Vector3d f = (at - eye).normalized();
  const Eigen::Vector3d right = f.cross(Eigen::Vector3d::UnitY());
  if (right.norm() < 1e-6) throw Error("camera_looking_at: looking straight up or down");
  RigidTransform t;
  t.rotation.col(0) = right.normalized();
  t.rotation.col(1) = f.cross(t.rotation.col(0));
  t.rotation.col(2) = f;
  t.rotation = t.rotation * Eigen::AngleAxisd(roll_deg * M_PI / 180, Eigen::Vector3d::UnitZ());
  t.translation = eye;
  return t;
}

DepthImage render_sim_depth(const Intrinsics& intrinsics, const RigidTransform& world_from_camera,
                            const SimScene& scene, const DepthNoise& noise) {
  // The ray table of the last intrinsics rendered (per thread): tests render many images.
  thread_local Intrinsics cached_intrinsics;
  thread_local RayTable rays;
  if (rays.x.empty() || !(cached_intrinsics == intrinsics)) {
    rays = make_ray_table(intrinsics);
    cached_intrinsics = intrinsics;
  }
  const int w = intrinsics.width, h = intrinsics.height;
  std::vector<double> exact(static_cast<size_t>(w) * h, 0);  // depth z, metres; 0 = none
  std::vector<double> cosine(exact.size(), 1);      // |cos| between the ray and the surface normal
  std::vector<double> ray_length(exact.size(), 1);  // |(X/Z, Y/Z, 1)|: distance along ray per z
  const Eigen::Vector3d o = world_from_camera.translation;
  const std::vector<Part> parts = place(scene);
  std::vector<Eigen::Vector3d> dirs;  // the tile's unit rays in the world frame
  std::vector<int> tile_parts;
  for (int ty = 0; ty < h; ty += kTile)
    for (int tx = 0; tx < w; tx += kTile) {
      const int y_end = std::min(h, ty + kTile), x_end = std::min(w, tx + kTile);
      dirs.clear();
      for (int y = ty; y < y_end; ++y)
        for (int x = tx; x < x_end; ++x) {
          const size_t i = static_cast<size_t>(y) * w + x;
          if (!std::isfinite(rays.x[i]) || !std::isfinite(rays.y[i])) continue;
          dirs.push_back((world_from_camera.rotation * Eigen::Vector3d(rays.x[i], rays.y[i], 1.0))
                             .normalized());
        }
      parts_in_cone(o, dirs, parts, tile_parts);
      size_t next = 0;  // the tile's valid rays, in the order `dirs` holds them
      for (int y = ty; y < y_end; ++y)
        for (int x = tx; x < x_end; ++x) {
          const size_t i = static_cast<size_t>(y) * w + x;
          if (!std::isfinite(rays.x[i]) || !std::isfinite(rays.y[i])) continue;
          const Eigen::Vector3d ray_cam(rays.x[i], rays.y[i], 1.0);
          const Eigen::Vector3d& d = dirs[next++];
          Hit hit;
          for (const int p : tile_parts) {
            const Part& part = parts[p];
            if (part.kind == Part::Kind::kSphere)
              sphere(o, d, part.centre, part.radius, hit);
            else
              cylinder(o, d, part.rod, part.radius, hit);
          }
          if (scene.floor && d.y() < -1e-9) {
            const double t = -o.y() / d.y();
            if (t > 1e-4 && t < hit.t) hit = {t, Eigen::Vector3d::UnitY()};
          }
          if (hit.t >= 1e8) continue;
          exact[i] = hit.t / ray_cam.norm();  // distance along the ray -> z
          cosine[i] = std::abs(hit.normal.dot(d));
          ray_length[i] = ray_cam.norm();
        }
    }
  std::mt19937 rng(noise.seed);
  std::normal_distribution<double> gauss;
  std::uniform_real_distribution<double> uniform(0, 1);
  DepthImage out(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      double z = exact[i];
      if (z <= 0) continue;
      if (cosine[i] < noise.grazing_cos || uniform(rng) < noise.dropout) continue;
      // A pixel on a depth edge mixes foreground and background (flying pixel).
      double other = z;
      for (const auto& [dx, dy] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
        const int nx = x + dx, ny = y + dy;
        if (nx < 0 || ny < 0 || nx >= w || ny >= h) continue;
        const double n = exact[static_cast<size_t>(ny) * w + nx];
        if (n > 0 && std::abs(n - z) > std::abs(other - z)) other = n;
      }
      if (std::abs(other - z) > 0.05 && uniform(rng) < noise.flying_pixels)
        z += (other - z) * uniform(rng);
      // Noise along the ray: sigma(z) in distance along it, z changes by that over |ray|.
      z += gauss(rng) * (noise.sigma_base_m + noise.sigma_per_m2 * z * z) / ray_length[i];
      if (z <= 0 || z > 5.46) continue;
      out.pixels[i] = static_cast<uint16_t>(std::lround(z * 1000));
    }
  return out;
}

}  // namespace volcast
