// LeaveOneOut (view_quality.hpp): each camera of a site held out in turn and the others drawn
// from its viewpoint, headless.
#include <fmt/format.h>

#include <algorithm>
#include <chrono>

#include "volcast/core/error.hpp"
#include "volcast/filter/filters.hpp"
#include "volcast/quality/view_quality.hpp"
#include "volcast/render/headless_target.hpp"
#include "volcast/render/view.hpp"

namespace volcast {
namespace {
constexpr float kNearM = 0.05f, kFarM = 30.0f;
}

struct LeaveOneOut::Impl {
  std::vector<CameraCalibration> cameras;   // as given: the others are drawn through these
  std::vector<CameraCalibration> pinholes;  // each camera's undistorted pinhole, same pose
  std::vector<DepthImage> real_depth;       // in the pinhole
  std::vector<ColorImage> real_color;       // in the pinhole; empty = none
  std::unique_ptr<HeadlessTarget> target;   // its context first made, last destroyed
  std::unique_ptr<CameraRenderer> renderer;
  std::vector<float> depth01;
  ColorImage shares;
};

LeaveOneOut::LeaveOneOut(std::vector<CameraCalibration> cameras, std::vector<CameraFrame> frames)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  if (cameras.size() != frames.size())
    throw Error(
        fmt::format("leave one out: {} cameras but {} frames", cameras.size(), frames.size()));
  if (cameras.size() < 2 || cameras.size() > 64)
    throw Error(
        fmt::format("leave one out: {} cameras (2..64 needed: one is held out)", cameras.size()));
  const int w = cameras[0].depth.width, h = cameras[0].depth.height;
  for (size_t k = 0; k < cameras.size(); ++k) {
    if (cameras[k].depth.width != w || cameras[k].depth.height != h)
      throw Error(fmt::format("leave one out: camera {} is {}x{}, camera 0 {}x{} (one size)", k,
                              cameras[k].depth.width, cameras[k].depth.height, w, h));
    const PixelMap map = make_pixel_map(cameras[k].depth, true, std::nullopt);
    CameraCalibration pinhole = cameras[k];
    pinhole.depth = map.output;
    m.pinholes.push_back(pinhole);
    DepthImage depth;
    apply_pixel_map(map, frames[k].depth, depth);
    m.real_depth.push_back(std::move(depth));
    ColorImage color;
    if (!frames[k].color.empty()) apply_pixel_map(map, frames[k].color, color);
    m.real_color.push_back(std::move(color));
  }
  m.cameras = std::move(cameras);
  m.target = std::make_unique<HeadlessTarget>(w, h);
  m.renderer = std::make_unique<CameraRenderer>();
  m.renderer->set_cameras(m.cameras);
  for (size_t k = 0; k < frames.size(); ++k) m.renderer->upload(k, frames[k]);
}

LeaveOneOut::~LeaveOneOut() {
  impl_->renderer.reset();  // its GL objects go while the target's context is current
  impl_->target.reset();
}

size_t LeaveOneOut::camera_count() const {
  return impl_->cameras.size();
}

void LeaveOneOut::set_world_from_camera(size_t camera, const RigidTransform& world_from_camera) {
  Impl& m = *impl_;
  if (camera >= m.cameras.size())
    throw Error(fmt::format("leave one out: no camera {} ({} cameras)", camera, m.cameras.size()));
  m.cameras[camera].world_from_camera = world_from_camera;
  m.pinholes[camera].world_from_camera = world_from_camera;
  m.renderer->set_world_from_camera(camera, world_from_camera);
}

LeaveOneOut::Result LeaveOneOut::run(const CameraPassOptions& options) {
  Impl& m = *impl_;
  const size_t n = m.cameras.size();
  const int w = m.target->width(), h = m.target->height();
  const size_t pixels = static_cast<size_t>(w) * static_cast<size_t>(h);
  Result result;
  std::vector<double> ms;
  for (size_t k = 0; k < n; ++k) {
    CameraPassOptions o = options;
    o.cameras.resize(n);
    for (size_t j = 0; j < n; ++j) o.cameras[j].visible = j != k;
    const View view = camera_view(m.pinholes[k], kNearM, kFarM);
    ViewImages v;
    m.target->finish();
    const auto t0 = std::chrono::steady_clock::now();
    m.renderer->draw_cameras(view, m.target->target(), o);
    m.target->finish();
    ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    m.target->read_image(v.rendered);
    m.target->read_depth(m.depth01);
    v.rendered_depth_m.resize(pixels);
    for (size_t i = 0; i < pixels; ++i)
      v.rendered_depth_m[i] = view_depth_m(view.clip_from_view, m.depth01[i]);
    // Which camera dominates each pixel: the others drawn in one-hot tints, three at a time
    // (red, green, blue); a blended pixel's tint is each camera's share of its weight.
    v.source.assign(pixels, kNoSource);
    std::vector<float> best(pixels, 0);
    std::vector<size_t> others;
    for (size_t j = 0; j < n; ++j)
      if (j != k) others.push_back(j);
    for (size_t first = 0; first < others.size(); first += 3) {
      CameraPassOptions t = o;
      for (size_t j = 0; j < n; ++j) t.cameras[j].tint = {0, 0, 0, 1};
      for (size_t g = first; g < std::min(first + 3, others.size()); ++g) {
        Eigen::Vector4f tint(0, 0, 0, 1);
        tint[static_cast<Eigen::Index>(g - first)] = 1;
        t.cameras[others[g]].tint = tint;
      }
      m.renderer->draw_cameras(view, m.target->target(), t);
      m.target->read_image(m.shares);
      for (size_t i = 0; i < pixels; ++i) {
        if (v.rendered_depth_m[i] <= 0) continue;
        for (size_t g = first; g < std::min(first + 3, others.size()); ++g) {
          const float share = m.shares.bgra[i * 4 + 2 - (g - first)] / 255.0f;  // BGRA: R first
          if (share > best[i]) {
            best[i] = share;
            v.source[i] = static_cast<uint8_t>(others[g]);
          }
        }
      }
    }
    v.real_depth = m.real_depth[k];
    v.real_color = m.real_color[k];
    result.scores.push_back(score_view(v));
    result.views.push_back(std::move(v));
  }
  std::sort(ms.begin(), ms.end());
  result.ms_per_frame = ms[ms.size() / 2];
  return result;
}

}  // namespace volcast
