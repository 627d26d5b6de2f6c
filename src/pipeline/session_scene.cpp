#include "volcast/pipeline/session_scene.hpp"

#include <spdlog/spdlog.h>

#include <chrono>

#include "volcast/core/clock.hpp"
#include "volcast/core/image_io.hpp"
#include "volcast/pipeline/receiver.hpp"
#include "volcast/render/annotation_scene.hpp"
#include "volcast/render/case_renderer.hpp"
#include "volcast/render/headless_target.hpp"
#include "volcast/render/primitive_renderer.hpp"
#include "volcast/render/room_scene.hpp"

namespace volcast {
namespace {

// A camera slot of the renderer: what it shows, to tell when the set changes.
struct Slot {
  uint32_t participant = 0;  // 0: a site camera
  int width = 0, height = 0;
  bool operator==(const Slot&) const = default;
};

RigidTransform to_rigid(const Pose& p) {
  RigidTransform t;
  t.rotation = p.orientation.normalized().toRotationMatrix().cast<double>();
  t.translation = p.position.cast<double>();
  return t;
}

}  // namespace

AvatarFilter remote_avatar_filter(const RemoteParticipant& other, float radius_m) {
  AvatarFilter f;
  if (other.has_pose) f.keep = KeepSphere{other.pose.head.position, radius_m};
  return f;
}

AvatarFilter own_camera_filter(const SessionSnapshot& s, float radius_m) {
  // You see your own body from your camera (not the room it stands in), without the headset
  // right in front of your eyes.
  AvatarFilter f;
  if (s.has_own_body) {
    f.keep = KeepSphere{s.own_body.head.position, radius_m};
    f.hide = HideBox{to_rigid(s.own_body.head)};
  }
  return f;
}

void drawing_primitives(const SessionSnapshot& s, const Eigen::Vector3f& eye,
                        std::vector<Primitive>& out, const DrawingOptions& options) {
  for (const PointerView& p : s.pointers) {
    if (!options.own_pointer && p.participant == s.id) continue;
    const auto beam = pointer_primitives(p.origin, p.has_hit, p.hit,
                                         participant_color(p.participant), eye, options.lift_per_m);
    out.insert(out.end(), beam.begin(), beam.end());
  }
  for (const session::Annotation& a : s.annotations) {
    if (a.anchor == session::AnnotationAnchor::kMonitor &&
        (!options.on_monitor || !s.monitor || s.monitor->slice != a.slice ||
         a.generation != s.case_generation))
      continue;                      // drawn on another CT slice (or case)
    session::Annotation lifted = a;  // out of the surface it was drawn on, for this eye
    for (Eigen::Vector3f& p : lifted.points) p = toward_eye(p, eye, options.lift_per_m);
    const auto shape = annotation_primitives(lifted, participant_color(a.author));
    out.insert(out.end(), shape.begin(), shape.end());
  }
}

std::vector<Primitive> annotation_primitives(const session::Annotation& a,
                                             const Eigen::Vector3f& rgb) {
  const auto& p = a.points;
  switch (a.kind) {
    case session::AnnotationKind::kStroke:
      return stroke_primitives(p, rgb);
    case session::AnnotationKind::kArrow:
      return p.size() == 2 ? arrow_primitives(p[0], p[1], rgb) : std::vector<Primitive>{};
    case session::AnnotationKind::kLabel:
      return p.size() == 1 ? label_pin_primitives(p[0], rgb) : std::vector<Primitive>{};
  }
  return {};
}

Eigen::Vector3f label_anchor(const session::Annotation& a) {
  return a.points.empty() ? Eigen::Vector3f::Zero() : label_anchor(a.points[0]);
}

View participant_eye(const SessionSnapshot& s, float aspect) {
  View v;
  if (s.has_own_body) {
    v.world_from_view = to_rigid(s.own_body.head);
  } else {
    v.world_from_view = session::room_from_playarea(s.spot);
    v.world_from_view.translation.y() = 1.6;
  }
  v.clip_from_view = perspective(90, aspect, 0.05f, 50);
  return v;
}

struct SessionScene::Impl {
  CameraRenderer cameras;
  PrimitiveRenderer primitives;
  CaseRenderer case_objects;
  std::vector<PlacedObject> placed;
  std::vector<Slot> slots;
  std::vector<std::shared_ptr<const CameraFrame>> uploaded;
  std::vector<CameraCalibration> calibrations;
  std::vector<Primitive> room, scene;
  bool room_made = false;
};

SessionScene::SessionScene() : impl_(std::make_unique<Impl>()) {}
SessionScene::~SessionScene() = default;

std::string SessionScene::gl_description() const {
  return impl_->cameras.gl_description();
}

void SessionScene::draw_primitives(const View& view, const RenderTarget& target,
                                   std::span<const Primitive> primitives) {
  Lighting light;
  light.point_position = default_operating_room().lamp_position;
  impl_->primitives.draw(view, target, primitives, light);
}

size_t SessionScene::cameras_drawn() const {
  return impl_->slots.size();
}

void SessionScene::draw(const View& view, const RenderTarget& target,
                        std::span<const CameraCalibration> site,
                        std::span<const std::shared_ptr<const CameraFrame>> site_frames,
                        Participant& participant, int64_t now_us,
                        const SessionSceneOptions& options) {
  Impl& r = *impl_;
  const SessionSnapshot s = participant.snapshot(now_us);
  // This frame's cameras: the site's (in the room), the others' avatars, the own camera.
  std::vector<Slot> slots;
  std::vector<CameraCalibration> calibrations;
  std::vector<std::shared_ptr<const CameraFrame>> frames;
  std::vector<AvatarFilter> filters;
  for (size_t i = 0; i < site.size(); ++i) {
    CameraCalibration c = site[i];
    c.world_from_camera = s.room_from_site * c.world_from_camera;
    slots.push_back({0, c.depth.width, c.depth.height});
    calibrations.push_back(c);
    frames.push_back(i < site_frames.size() ? site_frames[i] : nullptr);
    filters.push_back({});
  }
  r.scene.clear();
  for (const RemoteParticipant& p : s.others) {
    if (p.role == session::Role::kOrSite) continue;  // its cameras are the site's
    const auto frame = p.avatar_camera ? participant.avatar_frame(p.id) : nullptr;
    if (frame) {
      slots.push_back({p.id, p.avatar_camera->depth.width, p.avatar_camera->depth.height});
      calibrations.push_back(*p.avatar_camera);
      frames.push_back(frame);
      filters.push_back(remote_avatar_filter(p, options.keep_radius_m));
    } else if (p.has_pose) {
      const auto mesh = mesh_avatar_primitives(p.pose, participant_color(p.id));
      r.scene.insert(r.scene.end(), mesh.begin(), mesh.end());
    }
  }
  if (options.show_own_camera)
    if (const auto own = participant.own_camera()) {
      if (const auto frame = participant.own_frame()) {
        slots.push_back({s.id, own->depth.width, own->depth.height});
        calibrations.push_back(*own);
        frames.push_back(frame);
        filters.push_back(own_camera_filter(s, options.keep_radius_m));
      }
    }
  if (slots != r.slots) {
    r.cameras.set_cameras(calibrations);
    r.slots = slots;
    r.uploaded.assign(slots.size(), nullptr);
  } else {
    for (size_t i = 0; i < calibrations.size(); ++i)
      r.cameras.set_world_from_camera(i, calibrations[i].world_from_camera);
  }
  upload_changed(r.cameras, frames, r.uploaded);
  for (size_t i = 0; i < frames.size(); ++i) r.cameras.set_avatar_filter(i, filters[i]);
  CameraPassOptions pass = options.pass;
  pass.cameras.clear();
  r.cameras.draw_cameras(view, target, pass);

  if (options.room) {
    if (!r.room_made) {
      r.room = room_primitives(default_operating_room());
      r.room_made = true;
    }
    r.scene.insert(r.scene.end(), r.room.begin(), r.room.end());
  }
  const int64_t now_server = now_us + participant.clock_offset_us();
  for (const TeleportSeen& t : s.teleports) {
    const float age = float(now_server - t.time_us) / 1e6f;
    for (const session::Spot& spot : {t.from, t.to}) {
      const auto fx = teleport_effect_primitives(
          {spot.x, 0, spot.z}, age, options.teleport_effect_s, participant_color(t.participant));
      r.scene.insert(r.scene.end(), fx.begin(), fx.end());
    }
  }
  // Who speaks (a voice packet in the last 300 ms: silence is not sent) and who is muted: over
  // the head, or for a remote participant without a pose (a replay's recorded speaker, anyone
  // before their first pose) over its spot 1.6 m high (a standing head), where its voice plays.
  for (const RemoteParticipant& p : s.others) {
    if (!p.has_pose && p.role != session::Role::kRemote) continue;
    const Eigen::Vector3f head =
        p.has_pose ? p.pose.head.position : Eigen::Vector3f(p.spot.x, 1.6f, p.spot.z);
    const bool speaking = p.last_voice_us != 0 && now_us - p.last_voice_us < 300'000;
    const float pulse = 0.5f + 0.5f * std::sin(float(now_us % 1'000'000) * 2e-6f * float(M_PI) * 3);
    const auto badge = voice_badge_primitives(head, speaking, p.muted, pulse);
    r.scene.insert(r.scene.end(), badge.begin(), badge.end());
  }
  if (options.volume_shown) {
    const auto bar = volume_bar_primitives(options.volume_shown->at, options.volume_shown->gain);
    r.scene.insert(r.scene.end(), bar.begin(), bar.end());
  }
  if (options.own_muted && s.has_own_body && s.own_body.hands_tracked) {
    const auto badge = muted_hand_primitives(s.own_body.left_hand.position);
    r.scene.insert(r.scene.end(), badge.begin(), badge.end());
  }
  if (options.world_from_head && s.recording.recording) {
    const auto badge = recording_badge_primitives(*options.world_from_head);
    r.scene.insert(r.scene.end(), badge.begin(), badge.end());
  }
  DrawingOptions marks;
  marks.own_pointer = options.own_pointer;
  drawing_primitives(s, view.world_from_view.translation.cast<float>(), r.scene, marks);
  const auto shared_case = options.show_case ? participant.shared_case() : nullptr;
  const RoomLayout& room = default_operating_room();
  if (shared_case && s.monitor && shared_case->monitor) {
    const auto status = monitor_status_primitives(room, s.monitor->slice,
                                                  shared_case->monitor->slices, s.monitor->overlay);
    r.scene.insert(r.scene.end(), status.begin(), status.end());
  }
  Lighting light;
  light.point_position = room.lamp_position;
  r.primitives.draw(view, target, r.scene, light);
  if (shared_case && s.case_generation == shared_case->generation) {
    r.placed.clear();
    for (const ObjectView& o : s.objects) r.placed.push_back({o.pose, o.owner ? 0.12f : 0.0f});
    r.case_objects.draw(view, target, *shared_case, r.placed, light);
    if (s.monitor && shared_case->monitor)
      r.case_objects.draw_monitor(view, target, *shared_case->monitor, *s.monitor,
                                  monitor_image_quad(room));
  }
}

}  // namespace volcast

namespace volcast {

Presenter session_presenter(const ViewerOptions& opt, std::function<Participant*()> participant,
                            SessionSceneOptions scene_options, double fps,
                            std::shared_ptr<LiveSurfaces> surfaces) {
  return [opt, participant, scene_options, fps, surfaces](FrameFeed& feed, ViewerResult& result) {
    HeadlessTarget target(opt.width, opt.height);  // before the renderers: it owns the context
    SessionScene scene;
    result.renderer = scene.gl_description();
    const std::vector<CameraCalibration>& site = feed.cameras();
    std::vector<std::shared_ptr<const CameraFrame>> frames(site.size());
    DrawPace pace(fps);  // the others move on their own: drawn at fps, new frames or not
    while (!feed.finished()) {
      if (!pace.take(feed, frames)) continue;
      Participant* p = participant();
      if (!p) continue;
      const int64_t t = wall_clock_us();
      const SessionSnapshot seen = p->snapshot(t);
      if (surfaces) surfaces->update(site, frames, seen.room_from_site);
      const View eye = participant_eye(seen, target.target().aspect());
      scene.draw(eye, target.target(), site, frames, *p, t, scene_options);
      target.finish();  // headless: "presented" once the picture is finished
      feed.presented();
      ++result.frames_rendered;
    }
    if (!opt.screenshot.empty() && result.frames_rendered > 0) {
      ColorImage image;
      target.read_image(image);
      write_color_png(opt.screenshot, image);
      spdlog::info("wrote {} (the participant's eye)", opt.screenshot.string());
    }
  };
}

}  // namespace volcast
