#include "volcast/reconstruct/ray_hit.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "volcast/core/error.hpp"

namespace volcast {
namespace {

// One sample: whether it is measurable (ray_hit.hpp), its gap Z - depth (metres) and pixel.
struct Sample {
  bool measurable = false;
  double gap_m = 0;
  int x = 0, y = 0;
};

// The ray in the camera frame: p(t) = origin + t * direction (metres, direction unit length).
struct CameraRay {
  const Intrinsics& k;
  const DepthImage& depth;
  Eigen::Vector3d origin, direction;

  Sample at(double t) const {
    Sample s;
    const Eigen::Vector3d p = origin + t * direction;
    if (!(p.z() > 1e-6)) return s;
    const auto uv = project_normalized(k, {p.x() / p.z(), p.y() / p.z()});
    if (!uv) return s;
    const double u = std::floor(uv->x() + 0.5), v = std::floor(uv->y() + 0.5);
    if (!(u >= 0 && v >= 0 && u < k.width && v < k.height)) return s;
    s.x = static_cast<int>(u);
    s.y = static_cast<int>(v);
    const uint16_t mm = depth.at(s.x, s.y);
    if (mm == 0) return s;
    s.measurable = true;
    s.gap_m = p.z() - mm * 0.001;
    return s;
  }
};

constexpr int kBisections = 24;

void check_ray(const Eigen::Vector3f& origin, const Eigen::Vector3f& direction,
               float max_distance_m, const RayMarch& march) {
  if (!origin.allFinite() || !direction.allFinite() || !(direction.norm() > 0))
    throw Error("hit_depth: the ray's origin and direction must be finite, the direction non-zero");
  if (!(max_distance_m >= 0) || !std::isfinite(max_distance_m))
    throw Error("hit_depth: max_distance_m must be finite and >= 0, got " +
                std::to_string(max_distance_m));
  if (!(march.step_m > 0) || !std::isfinite(march.step_m) || !(march.behind_tolerance_m >= 0) ||
      !std::isfinite(march.behind_tolerance_m) || march.max_steps < 1)
    throw Error("hit_depth: RayMarch needs step_m > 0, behind_tolerance_m >= 0, max_steps >= 1");
}

std::optional<RayHit> march_one(const CameraCalibration& camera, const DepthImage& depth,
                                const Eigen::Vector3f& origin_world,
                                const Eigen::Vector3f& direction_world, float max_distance_m,
                                const RayMarch& march) {
  const Intrinsics& k = camera.depth;
  if (depth.width != k.width || depth.height != k.height ||
      depth.pixels.size() != static_cast<size_t>(depth.width) * depth.height)
    throw Error("hit_depth: depth image is " + std::to_string(depth.width) + "x" +
                std::to_string(depth.height) + ", its calibration " + std::to_string(k.width) +
                "x" + std::to_string(k.height));
  const RigidTransform camera_from_world = camera.world_from_camera.inverse();
  const Eigen::Vector3d unit = direction_world.cast<double>().normalized();
  const CameraRay ray{k, depth, camera_from_world * origin_world.cast<double>(),
                      camera_from_world.rotation * unit};
  const double distance = max_distance_m;
  const double step = std::max<double>(march.step_m, distance / march.max_steps);
  const int steps = static_cast<int>(std::min<double>(std::ceil(distance / step), march.max_steps));
  Sample previous;  // not measurable
  double previous_t = 0;
  for (int i = 0; i <= steps; ++i) {
    const double t = std::min(i * step, distance);
    const Sample s = ray.at(t);
    if (s.measurable && s.gap_m >= 0 && previous.measurable && previous.gap_m < 0) {
      // From in front (previous_t) to behind (t): bisect to where it changes, then judge the
      // sample just behind that point.
      double front = previous_t, behind = t;
      Sample at_behind = s;
      for (int b = 0; b < kBisections && behind - front > 1e-5; ++b) {
        const double mid = 0.5 * (front + behind);
        const Sample m = ray.at(mid);
        if (m.measurable && m.gap_m < 0) {
          front = mid;
        } else {
          behind = mid;
          at_behind = m;
        }
      }
      if (at_behind.measurable && at_behind.gap_m <= march.behind_tolerance_m) {
        RayHit hit;
        hit.distance_m = static_cast<float>(behind);
        hit.point_world = (origin_world.cast<double>() + unit * behind).cast<float>();
        hit.pixel_x = at_behind.x;
        hit.pixel_y = at_behind.y;
        return hit;
      }
      // Behind a silhouette edge (or into a hole): the hidden region, not a surface.
    }
    previous = s;
    previous_t = t;
  }
  return std::nullopt;
}

}  // namespace

std::optional<RayHit> hit_depth(const CameraCalibration& camera, const DepthImage& depth,
                                const Eigen::Vector3f& origin_world,
                                const Eigen::Vector3f& direction_world, float max_distance_m,
                                const RayMarch& march) {
  check_ray(origin_world, direction_world, max_distance_m, march);
  return march_one(camera, depth, origin_world, direction_world, max_distance_m, march);
}

std::optional<RayHit> hit_depths(std::span<const CameraCalibration> cameras,
                                 std::span<const DepthImage* const> depths,
                                 const Eigen::Vector3f& origin_world,
                                 const Eigen::Vector3f& direction_world, float max_distance_m,
                                 const RayMarch& march) {
  if (cameras.size() != depths.size())
    throw Error("hit_depths: " + std::to_string(cameras.size()) + " cameras but " +
                std::to_string(depths.size()) + " depth images");
  check_ray(origin_world, direction_world, max_distance_m, march);
  std::optional<RayHit> nearest;
  for (size_t i = 0; i < cameras.size(); ++i) {
    if (!depths[i]) continue;
    // A hit further than the nearest so far cannot win: march only that far.
    const float limit = nearest ? nearest->distance_m : max_distance_m;
    auto hit = march_one(cameras[i], *depths[i], origin_world, direction_world, limit, march);
    if (hit && (!nearest || hit->distance_m < nearest->distance_m)) {
      hit->camera = i;
      nearest = hit;
    }
  }
  return nearest;
}

}  // namespace volcast
