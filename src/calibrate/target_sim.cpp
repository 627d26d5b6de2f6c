// The synthetic depth camera (SYNTHETIC data for tests and benchmarks): per pixel, the ray of the
// real lens model (make_ray_table) against the target's spheres, its rods (finite cylinders), extra
// balls and the floor; nearest hit; then Azure Kinect-like noise, flying pixels at depth edges,
// dropout and grazing-angle loss, deterministic for a seed.
#include "volcast/calibrate/target_sim.hpp"

#include <Eigen/Geometry>
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

void cylinder(const Eigen::Vector3d& o, const Eigen::Vector3d& d, const Eigen::Vector3d& a,
              const Eigen::Vector3d& b, double r, Hit& hit) {
  const Eigen::Vector3d axis = (b - a).normalized();
  const double length = (b - a).norm();
  const Eigen::Vector3d dp = d - axis * d.dot(axis), op = (o - a) - axis * (o - a).dot(axis);
  const double qa = dp.squaredNorm(), qb = 2 * dp.dot(op), qc = op.squaredNorm() - r * r;
  const double disc = qb * qb - 4 * qa * qc;
  if (qa < 1e-12 || disc < 0) return;
  const double t = (-qb - std::sqrt(disc)) / (2 * qa);
  if (t <= 1e-4 || t >= hit.t) return;
  const Eigen::Vector3d p = o + d * t;
  const double s = (p - a).dot(axis);
  if (s < 0 || s > length) return;
  hit = {t, (p - a - axis * s).normalized()};
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
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      if (!std::isfinite(rays.x[i]) || !std::isfinite(rays.y[i])) continue;
      const Eigen::Vector3d ray_cam(rays.x[i], rays.y[i], 1.0);
      const Eigen::Vector3d d = (world_from_camera.rotation * ray_cam).normalized();
      Hit hit;
      for (const auto& c : scene.target.centres_m)
        sphere(o, d, scene.world_from_target * c, scene.target.sphere_radius_m, hit);
      for (const auto& [a, b] : scene.target.rods_m)
        cylinder(o, d, scene.world_from_target * a, scene.world_from_target * b,
                 scene.target.rod_radius_m, hit);
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
