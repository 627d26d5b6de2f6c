// The synthetic depth camera (SYNTHETIC data for tests and benchmarks): per pixel, the ray of the
// real lens model (make_ray_table) against the target's spheres, its rods (finite cylinders), extra
// balls and the floor; nearest hit; then Azure Kinect-like noise, flying pixels at depth edges,
// dropout and grazing-angle loss, deterministic for a seed. The target is placed in the world once
// per image and only the rays that pass near it are tested against its parts.
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

// The target in the world frame, placed once per image, and a ball holding all of it (1 cm to
// spare): a ray that misses the ball meets none of its spheres and rods.
struct PlacedTarget {
  std::vector<Eigen::Vector3d> centres;
  std::vector<Rod> rods;
  Eigen::Vector3d bound_centre = Eigen::Vector3d::Zero();
  double bound_radius = 0;
};

PlacedTarget place(const SimScene& scene) {
  PlacedTarget t;
  const TargetModel& m = scene.target;
  for (const auto& c : m.centres_m) t.centres.push_back(scene.world_from_target * c);
  for (const auto& [a, b] : m.rods_m) {
    const Eigen::Vector3d wa = scene.world_from_target * a, wb = scene.world_from_target * b;
    t.rods.push_back({wa, (wb - wa).normalized(), (wb - wa).norm()});
  }
  std::vector<std::pair<Eigen::Vector3d, double>> parts;  // every sphere and rod end, its radius
  for (const auto& c : t.centres) parts.emplace_back(c, m.sphere_radius_m);
  for (const Rod& r : t.rods) {
    parts.emplace_back(r.a, m.rod_radius_m);
    parts.emplace_back(r.a + r.axis * r.length, m.rod_radius_m);
  }
  if (parts.empty()) return t;
  for (const auto& [p, r] : parts) t.bound_centre += p;
  t.bound_centre /= static_cast<double>(parts.size());
  for (const auto& [p, r] : parts)
    t.bound_radius = std::max(t.bound_radius, (p - t.bound_centre).norm() + r);
  t.bound_radius += 0.01;
  return t;
}

// Whether the line through `o` along unit `d` passes within the target's bound.
bool near_target(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const PlacedTarget& t) {
  if (t.bound_radius <= 0) return false;
  const Eigen::Vector3d oc = o - t.bound_centre;
  const double b = oc.dot(d);
  return b * b - (oc.squaredNorm() - t.bound_radius * t.bound_radius) >= 0;
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
  const PlacedTarget target = place(scene);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      if (!std::isfinite(rays.x[i]) || !std::isfinite(rays.y[i])) continue;
      const Eigen::Vector3d ray_cam(rays.x[i], rays.y[i], 1.0);
      const Eigen::Vector3d d = (world_from_camera.rotation * ray_cam).normalized();
      Hit hit;
      if (near_target(o, d, target)) {
        for (const auto& c : target.centres) sphere(o, d, c, scene.target.sphere_radius_m, hit);
        for (const Rod& rod : target.rods) cylinder(o, d, rod, scene.target.rod_radius_m, hit);
      }
      for (const auto& [c, r] : scene.extra_spheres) sphere(o, d, c, r, hit);
      if (scene.floor && d.y() < -1e-9) {
        const double t = -o.y() / d.y();
        if (t > 1e-4 && t < hit.t) hit = {t, Eigen::Vector3d::UnitY()};
      }
      if (hit.t >= 1e8) continue;
      exact[i] = hit.t / ray_cam.norm();  // distance along the ray -> z
      cosine[i] = std::abs(hit.normal.dot(d));
      ray_length[i] = ray_cam.norm();
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
