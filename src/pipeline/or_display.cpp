#include "volcast/pipeline/or_display.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <optional>

#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/image_io.hpp"
#include "volcast/filter/filters.hpp"
#include "volcast/pipeline/receiver.hpp"
#include "volcast/pipeline/session_scene.hpp"
#include "volcast/render/annotation_scene.hpp"
#include "volcast/render/backdrop_renderer.hpp"
#include "volcast/render/headless_target.hpp"
#include "volcast/render/primitive_renderer.hpp"
#include "volcast/render/room_scene.hpp"
#include "volcast/render/view.hpp"

namespace volcast {

OrDisplaySize or_display_size(const CameraCalibration& camera) {
  return {camera.depth.width, camera.depth.height};
}

struct OrDisplay::Impl {
  BackdropRenderer backdrop;
  PrimitiveRenderer primitives;
  Intrinsics mapped_for;  // the intrinsics `map` was made for
  PixelMap map;
  HoleFiller holes;
  CameraFrame undistorted;
  CameraCalibration room_camera;
  std::vector<Primitive> scene;
};

OrDisplay::OrDisplay() : impl_(std::make_unique<Impl>()) {
  impl_->holes.iterations = 10;  // a glove's holes, not only single pixels
}
OrDisplay::~OrDisplay() = default;

const CameraCalibration& OrDisplay::room_camera() const {
  return impl_->room_camera;
}

void OrDisplay::draw(const RenderTarget& target, const CameraCalibration& camera,
                     const CameraFrame& frame, const SessionSnapshot& s, int64_t now_us) {
  Impl& r = *impl_;
  if (frame.depth.width != camera.depth.width || frame.depth.height != camera.depth.height)
    throw Error("OR display: the frame is " + std::to_string(frame.depth.width) + "x" +
                std::to_string(frame.depth.height) + ", its camera " +
                std::to_string(camera.depth.width) + "x" + std::to_string(camera.depth.height));
  if (r.map.map.empty() || !(r.mapped_for == camera.depth)) {
    r.map = make_pixel_map(camera.depth, true, std::nullopt);
    r.mapped_for = camera.depth;
  }
  apply_pixel_map(r.map, frame.depth, r.undistorted.depth);
  if (!frame.color.empty())
    apply_pixel_map(r.map, frame.color, r.undistorted.color);
  else
    r.undistorted.color = ColorImage{};
  r.holes.apply(r.undistorted.depth);
  r.room_camera.depth = r.map.output;
  r.room_camera.world_from_camera = s.room_from_site * camera.world_from_camera;
  const View view = camera_view(r.room_camera, 0.05f, 20);
  r.backdrop.draw(view, target, r.undistorted);

  r.scene.clear();
  for (const RemoteParticipant& p : s.others) {
    if (p.role != session::Role::kRemote || !p.has_pose) continue;
    const auto mesh = mesh_avatar_primitives(p.pose, participant_color(p.id));
    r.scene.insert(r.scene.end(), mesh.begin(), mesh.end());
    const bool speaking = p.last_voice_us != 0 && now_us - p.last_voice_us < 300'000;
    const auto badge = voice_badge_primitives(p.pose.head.position, speaking, p.muted, 0.5f);
    r.scene.insert(r.scene.end(), badge.begin(), badge.end());
  }
  // Not those on the virtual room's wall monitor: the real OR has none to draw them on. A mark
  // drawn on the fused clouds lies off this camera's own surface by the cameras' registration
  // error, which grows with distance (up to 11 cm at 4 m in the demo's four Kinects): lifted by
  // 2 cm + 3 % of its distance, 6.5 cm at 1.5 m (a hand over the patient still hides it).
  DrawingOptions marks;
  marks.on_monitor = false;
  marks.lift_per_m = kOrDisplayLiftPerM;
  drawing_primitives(s, view.world_from_view.translation.cast<float>(), r.scene, marks);
  if (!r.scene.empty()) r.primitives.draw(view, target, r.scene);
}

std::vector<OrDisplayLabel> OrDisplay::labels(const SessionSnapshot& s) const {
  const Impl& r = *impl_;
  std::vector<OrDisplayLabel> out;
  const Intrinsics& k = r.room_camera.depth;
  const DepthImage& depth = r.undistorted.depth;
  if (k.width <= 0 || depth.width != k.width || depth.height != k.height) return out;
  const RigidTransform camera_from_room = r.room_camera.world_from_camera.inverse();
  const auto project = [&](const Eigen::Vector3f& room) -> std::optional<Eigen::Vector3d> {
    const Eigen::Vector3d p = camera_from_room * room.cast<double>();
    if (!(p.z() > 0.05)) return std::nullopt;  // behind the camera or at its lens
    return Eigen::Vector3d(k.fx * p.x() / p.z() + k.cx, k.fy * p.y() / p.z() + k.cy, p.z());
  };
  for (const session::Annotation& a : s.annotations) {
    if (a.kind != session::AnnotationKind::kLabel ||
        a.anchor == session::AnnotationAnchor::kMonitor || a.points.empty())
      continue;
    // Shown while its pin is: in the picture and not behind a real surface.
    const auto pin = project(a.points[0]);
    if (!pin || !(pin->x() >= 0 && pin->y() >= 0 && pin->x() < k.width && pin->y() < k.height))
      continue;
    const uint16_t live_mm = depth.at(static_cast<int>(pin->x()), static_cast<int>(pin->y()));
    // A real surface in front (beyond the lift the pin is drawn with).
    const double lift_mm = 20 + 1000 * kOrDisplayLiftPerM * pin->z();
    if (live_mm != 0 && live_mm + lift_mm < pin->z() * 1000) continue;
    // The text over the stick's top, kept inside the picture (a pin near its edge keeps its text).
    const auto top = project(label_anchor(a));
    const Eigen::Vector2d at = top ? top->head<2>() : pin->head<2>();
    out.push_back({a.text,
                   Eigen::Vector2f(float(std::clamp(at.x(), 0.0, double(k.width))),
                                   float(std::clamp(at.y(), 0.0, double(k.height)))),
                   participant_color(a.author)});
  }
  return out;
}

int upright_quarter_turns(const RigidTransform& room_from_camera) {
  // The room's up as the image shows it: (u, v) of a step up, v pointing down the image.
  const Eigen::Vector3d up = room_from_camera.rotation.transpose() * Eigen::Vector3d::UnitY();
  if (std::abs(up.x()) > std::abs(up.y())) return up.x() > 0 ? 1 : 3;
  return up.y() > 0 ? 2 : 0;
}

ColorImage turned(const ColorImage& image, int quarter_turns) {
  const int k = ((quarter_turns % 4) + 4) % 4;
  if (k == 0) return image;
  const int w = image.width, h = image.height;
  ColorImage out(k == 2 ? w : h, k == 2 ? h : w);
  for (int y = 0; y < out.height; ++y)
    for (int x = 0; x < out.width; ++x) {
      const int sx = k == 1 ? w - 1 - y : k == 2 ? w - 1 - x : y;
      const int sy = k == 1 ? x : k == 2 ? h - 1 - y : h - 1 - x;
      std::copy_n(image.pixel(sx, sy), 4, out.pixel(x, y));
    }
  return out;
}

Eigen::Vector2f turned_point(const Eigen::Vector2f& p, int width, int height, int quarter_turns) {
  const auto w = static_cast<float>(width), h = static_cast<float>(height);
  switch (((quarter_turns % 4) + 4) % 4) {
    case 1:
      return {p.y(), w - p.x()};
    case 2:
      return {w - p.x(), h - p.y()};
    case 3:
      return {h - p.y(), p.x()};
    default:
      return p;
  }
}

Presenter or_display_presenter(const ViewerOptions& opt, size_t camera,
                               std::function<Participant*()> participant, double fps) {
  return [opt, camera, participant, fps](FrameFeed& feed, ViewerResult& result) {
    const std::vector<CameraCalibration>& site = feed.cameras();
    if (camera >= site.size())
      throw Error("OR display: the site has " + std::to_string(site.size()) +
                  " cameras, no camera " + std::to_string(camera));
    const OrDisplaySize size = or_display_size(site[camera]);
    HeadlessTarget target(size.width, size.height);  // before the renderers: it owns the context
    OrDisplay display;
    std::vector<std::shared_ptr<const CameraFrame>> frames(site.size());
    DrawPace pace(fps);
    bool drawn = false;
    while (!feed.finished()) {
      if (!pace.take(feed, frames)) continue;
      Participant* p = participant();
      if (!p || !frames[camera]) continue;
      const int64_t t = wall_clock_us();
      display.draw(target.target(), site[camera], *frames[camera], p->snapshot(t), t);
      target.finish();  // headless: "presented" once the picture is finished
      feed.presented();
      drawn = true;
      ++result.frames_rendered;
    }
    if (!opt.screenshot.empty() && drawn) {
      ColorImage image;
      target.read_image(image);
      write_color_png(
          opt.screenshot,
          turned(image, upright_quarter_turns(display.room_camera().world_from_camera)));
      spdlog::info("wrote {} (the OR display of camera {})", opt.screenshot.string(), camera);
    }
  };
}

}  // namespace volcast
