#include "volcast/calibrate/preview.hpp"

#include <algorithm>
#include <cmath>

#include "volcast/core/image_io.hpp"
#include "volcast/core/ray_table.hpp"
#include "volcast/reconstruct/point_cloud.hpp"
#include "volcast/render/camera_renderer.hpp"
#include "volcast/render/headless_target.hpp"
#include "volcast/render/view.hpp"

namespace volcast {
namespace {

constexpr float kTints[8][3] = {{1, 0.2f, 0.2f}, {0.2f, 1, 0.2f}, {0.3f, 0.4f, 1}, {1, 0.9f, 0.1f},
                                {1, 0.2f, 1},    {0.1f, 1, 1},    {1, 0.6f, 0.1f}, {1, 1, 1}};

// An orthographic projection of the box |x| <= half_w, |y| <= half_h, near..far in front of the
// eye.
Eigen::Matrix4f orthographic(float half_w, float half_h, float near_m, float far_m) {
  Eigen::Matrix4f m = Eigen::Matrix4f::Identity();
  m(0, 0) = 1 / half_w;
  m(1, 1) = 1 / half_h;
  m(2, 2) = -2 / (far_m - near_m);
  m(2, 3) = -(far_m + near_m) / (far_m - near_m);
  return m;
}

// The 2nd and 98th percentile of each coordinate of the points (outliers left out).
void bounds(const std::vector<Eigen::Vector3d>& points, Eigen::Vector3d& lo, Eigen::Vector3d& hi) {
  std::vector<double> v(points.size());
  for (int axis = 0; axis < 3; ++axis) {
    for (size_t i = 0; i < points.size(); ++i) v[i] = points[i](axis);
    const size_t a = v.size() / 50, b = v.size() - 1 - v.size() / 50;
    std::nth_element(v.begin(), v.begin() + static_cast<long>(a), v.end());
    lo(axis) = v[a];
    std::nth_element(v.begin(), v.begin() + static_cast<long>(b), v.end());
    hi(axis) = v[b];
  }
}

}  // namespace

void write_calibration_preview(const std::filesystem::path& png,
                               std::span<const CameraCalibration> cameras,
                               std::span<const CameraFrame> frames, bool room_aligned) {
  // Seen from above, the ceiling would hide the room: in the room frame, leave out what lies above
  // the highest camera (plus 0.25 m).
  std::vector<CameraFrame> shown(frames.begin(), frames.end());
  if (room_aligned) {
    double cut = -1e9;
    for (const auto& c : cameras) cut = std::max(cut, c.world_from_camera.translation.y() + 0.25);
    for (size_t i = 0; i < cameras.size() && i < shown.size(); ++i) {
      const RayTable rays = make_ray_table(cameras[i].depth);
      const RigidTransform& w = cameras[i].world_from_camera;
      DepthImage& d = shown[i].depth;
      if (d.width != rays.width || d.height != rays.height) continue;
      for (size_t k = 0; k < d.pixels.size(); ++k) {
        const double z = d.pixels[k] * 1e-3;
        if (z > 0 && (w * Eigen::Vector3d(rays.x[k] * z, rays.y[k] * z, z)).y() > cut)
          d.pixels[k] = 0;
      }
    }
  }
  frames = shown;
  std::vector<Eigen::Vector3d> points;
  for (size_t i = 0; i < cameras.size() && i < frames.size(); ++i) {
    PointCloud cloud;
    CloudBuilder(cameras[i]).build(frames[i].depth, ColorImage{}, cloud);
    for (size_t k = 0; k < cloud.points.size(); k += 7) {
      const float* p = cloud.points[k].position;
      points.emplace_back(p[0], p[1], p[2]);
    }
  }
  Eigen::Vector3d lo = Eigen::Vector3d::Zero(), hi = Eigen::Vector3d::Ones();
  if (points.size() > 100) bounds(points, lo, hi);
  const Eigen::Vector3d centre = (lo + hi) / 2;
  const double size = std::max((hi - lo).maxCoeff(), 0.5);
  // Up and forward of the picture.
  Eigen::Vector3d up = Eigen::Vector3d::UnitY(), forward = Eigen::Vector3d::UnitZ();
  if (!room_aligned && !cameras.empty()) {
    up = -cameras[0].world_from_camera.rotation.col(1);
    forward = cameras[0].world_from_camera.rotation.col(2);
    forward = (forward - up * up.dot(forward)).normalized();
  }
  const int w = 960, h = 720;
  HeadlessTarget target(2 * w, h);
  CameraRenderer renderer;
  std::vector<CameraCalibration> cals(cameras.begin(), cameras.end());
  renderer.set_cameras(cals);
  for (size_t i = 0; i < cals.size() && i < frames.size(); ++i) renderer.upload(i, frames[i]);
  CameraPassOptions o;
  o.splat_size = SplatSize::kFixedPixels;
  o.fixed_point_px = 2;
  o.blend = false;
  for (size_t i = 0; i < cals.size(); ++i)
    o.cameras.push_back(CameraLook{
        true, Eigen::Vector4f(kTints[i % 8][0], kTints[i % 8][1], kTints[i % 8][2], 0.75f)});
  const float half = static_cast<float>(size) * 0.6f;
  const float aspect = static_cast<float>(w) / static_cast<float>(h);
  const float far_m = static_cast<float>(size) * 4;
  // Left: from above, the picture's top toward `forward`. Right: from the side, looking along
  // `forward`, up toward `up`.
  RenderTarget left = target.target(), right = target.target();
  left.width = w;
  right.x = w;
  right.width = w;
  View top, side;
  top.world_from_view = look_at(centre + up * size * 2, centre, forward);
  top.clip_from_view = orthographic(half * aspect, half, 0.01f, far_m);
  side.world_from_view = look_at(centre - forward * size * 2, centre, up);
  side.clip_from_view = orthographic(half * aspect, half, 0.01f, far_m);
  renderer.draw_cameras(top, left, o);
  renderer.draw_cameras(side, right, o);
  ColorImage image;
  target.read_image(image);
  write_color_png(png, image);
}

}  // namespace volcast
