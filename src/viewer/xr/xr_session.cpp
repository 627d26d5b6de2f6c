// The OpenXR presenter: the frame loop over the rig (xr_rig.hpp: the instance, the session bound
// to a hidden GLFW window's GLX context, stereo swapchains with an FBO each).
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>
#include <vector>

#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/pipeline/hand_grab.hpp"
#include "volcast/pipeline/hand_pointing.hpp"
#include "volcast/pipeline/live_surfaces.hpp"
#include "volcast/pipeline/session_scene.hpp"
#include "volcast/pipeline/viewer_result.hpp"
#include "volcast/render/annotation_scene.hpp"
#include "volcast/viewer/xr.hpp"
#include "volcast/viewer/xr_view.hpp"
#include "volcast/voice/voice_controls.hpp"
#include "xr_common.hpp"
#include "xr_controllers.hpp"
#include "xr_rig.hpp"

namespace volcast {
namespace {

using xr::HiddenContext;
using xr::kStereo;
using xr::Lost;
using xr::xr_check_live;
using xr::XrRig;

// The frame loop's state (render thread): what it draws with and what it keeps between frames.
struct FrameLoop {
  const XrOptions& o;
  XrRig& rig;
  CameraRenderer& renderer;
  SessionScene* scene;       // with a participant
  Participant* participant;  // null: a plain viewer
  XrControllers& controllers;
  const std::vector<CameraCalibration>& cameras;
  HandGrab hand_grab;
  HandPointing hand_pointing;                   // the right controller's laser pointer and drawing
  bool label_down = false, erase_down = false;  // the label and erase buttons, last frame
  LiveSurfaces surfaces;                        // where its ray meets the live clouds
  bool surfaces_stale = true;                   // a frame arrived since `surfaces` was updated
  RigidTransform surfaces_site;                 // the room_from_site `surfaces` was updated with
  Eigen::Vector3f own_color = Eigen::Vector3f::Ones();
  voice::VoiceInput voice_input;        // the voice buttons' requests (talk held, mute pressed)
  voice::VoiceButtons voice_buttons;    // as they were last frame
  voice::VolumeGesture volume_gesture;  // the left thumbstick's volume steps
  std::vector<std::shared_ptr<const CameraFrame>> frames, uploaded;
  std::vector<XrView> views;
  std::vector<XrCompositionLayerProjectionView> projected;
  RigidTransform world_from_stage_now;
  bool running = false;    // between READY and STOPPING (poll_events)
  bool started = false;    // the stream's first frame arrived: the view is set, frames are counted
  CameraPassOptions pass;  // o.pass, blending turned off by o.blend or the budget
  FrameBudget budget{1'000'000 / 90};  // the runtime's period replaces this one's
  XrTime last_display = 0;             // the last frame's predicted display time (ns)
  bool last_blended = false;           // whether that frame was drawn blended
  std::string blend_off;               // budget.reason(), once it turned blending off

  FrameLoop(const XrOptions& options, XrRig& xr_rig, CameraRenderer& camera_renderer,
            SessionScene* session_scene, Participant* joined, XrControllers& xr_controllers,
            const std::vector<CameraCalibration>& site_cameras)
      : o(options),
        rig(xr_rig),
        renderer(camera_renderer),
        scene(session_scene),
        participant(joined),
        controllers(xr_controllers),
        cameras(site_cameras),
        uploaded(cameras.size()),
        views(rig.view_count, xr_struct<XrView>(XR_TYPE_VIEW)),
        projected(rig.view_count),
        world_from_stage_now(world_from_stage(ViewCamera{}, rig.eye_height)),
        pass(options.pass) {
    if (o.blend == BlendPolicy::kOff) pass.blend = false;
  }

  // The frame budget (BlendPolicy::kAuto): the interval between the last frame's display time and
  // this one's, against the runtime's display period, counts for the last frame.
  void keep_budget(const XrFrameState& frame) {
    if (o.blend == BlendPolicy::kAuto && frame.predictedDisplayPeriod > 0) {
      budget.set_period(frame.predictedDisplayPeriod / 1000);
      if (last_display > 0 &&
          budget.add((frame.predictedDisplayTime - last_display) / 1000, last_blended)) {
        pass.blend = false;
        blend_off = budget.reason();
        spdlog::warn("OpenXR: {}", blend_off);
      }
    }
    last_display = frame.predictedDisplayTime;
    last_blended = false;
  }

  // Takes new frames from the feed (waiting only while not running), uploads the cameras whose
  // frame changed and, at the first, places the stage (XrOptions::view or default_view()).
  void take_frames(FrameFeed& feed) {
    // Not running: wait for the runtime (and the stream) without spinning.
    const auto wait = running ? std::chrono::microseconds(0) : std::chrono::milliseconds(10);
    feed.next(frames, wait);
    if (upload_changed(renderer, frames, uploaded) > 0) surfaces_stale = true;
    if (!started && std::any_of(uploaded.begin(), uploaded.end(), [](auto& f) { return !!f; })) {
      started = true;
      world_from_stage_now =
          world_from_stage(o.view ? *o.view : default_view(cameras, uploaded), rig.eye_height);
    }
  }

  // With a participant: publishes its head (the eyes' midpoint, the first eye's orientation) and
  // hands (the controllers' grips), lets a squeezing hand grab a case object or move the one it
  // holds, and follows its play area in the room (its teleports) with the stage.
  void track_participant(const XrFrameState& frame, int64_t now) {
    const uint32_t view_count = rig.view_count;
    // The stage is the play area; a LOCAL space starts at the head, so it is lifted.
    const float lift = rig.eye_height > 0 ? 0 : o.eye_height_m;
    BodyPose body;
    for (uint32_t i = 0; i < view_count; ++i) {
      const XrVector3f& p = views[i].pose.position;
      body.head.position += Eigen::Vector3f(p.x, p.y + lift, p.z) / float(view_count);
    }
    const XrQuaternionf& q = views[0].pose.orientation;
    body.head.orientation = Eigen::Quaternionf(q.w, q.x, q.y, q.z).normalized();
    // The controllers: published as the hands; a squeeze near an organ grabs it.
    const auto hands = controllers.sync(rig.space.handle, frame.predictedDisplayTime);
    Pose* grips[2] = {&body.left_hand, &body.right_hand};
    for (int h = 0; h < 2; ++h)
      if (hands[h].tracked) {
        *grips[h] = hands[h].pose;
        grips[h]->position.y() += lift;
      }
    body.hands_tracked = hands[0].tracked && hands[1].tracked;
    participant->publish(body);
    const SessionSnapshot snapshot = participant->snapshot(now);
    RigidTransform stage_lift;
    stage_lift.translation.y() = lift;
    const RigidTransform room_from_playarea = session::room_from_playarea(snapshot.spot);
    world_from_stage_now = room_from_playarea * stage_lift;
    std::array<HandInput, 2> grab_input;
    const Eigen::Quaternionf turn(room_from_playarea.rotation.cast<float>());
    for (int h = 0; h < 2; ++h) {
      grab_input[h].tracked = hands[h].tracked;
      grab_input[h].squeeze = hands[h].squeeze;
      grab_input[h].room_from_hand.position =
          (room_from_playarea * grips[h]->position.cast<double>()).cast<float>();
      grab_input[h].room_from_hand.orientation = (turn * grips[h]->orientation).normalized();
    }
    hand_grab.update(*participant, snapshot, grab_input);
    track_pointer(hands, snapshot, room_from_playarea, lift);
    track_voice_buttons(hands[0], snapshot, now);
  }

  // The right controller's laser pointer (A held), drawing (B held) and labels (its thumbstick
  // pressed) from its aim ray, the hit where the ray meets the live clouds, and erasing (the left
  // thumbstick pressed) (hand_pointing.hpp, xr_controllers.hpp).
  void track_pointer(const std::array<ControllerState, 2>& hands, const SessionSnapshot& snapshot,
                     const RigidTransform& room_from_playarea, float lift) {
    const ControllerState& right = hands[1];
    if (surfaces_stale || snapshot.room_from_site.translation != surfaces_site.translation ||
        snapshot.room_from_site.rotation != surfaces_site.rotation) {
      surfaces.update(cameras, uploaded, snapshot.room_from_site);
      surfaces_site = snapshot.room_from_site;
      surfaces_stale = false;
    }
    PointerInput in;
    in.tracked = right.aim_tracked;
    in.point = right.point;
    in.draw = right.draw;
    if (right.label && !label_down)
      in.label = labeled_preset(right.label_stick.x(), right.label_stick.y());
    in.erase = hands[0].erase && !erase_down;
    label_down = right.label;
    erase_down = hands[0].erase;
    const Eigen::Vector3d aim_at(right.aim.position.x(), right.aim.position.y() + lift,
                                 right.aim.position.z());
    in.origin = (room_from_playarea * aim_at).cast<float>();
    in.direction = (room_from_playarea.rotation.cast<float>() *
                    (right.aim.orientation * Eigen::Vector3f(0, 0, -1)));
    const int64_t now_us = std::chrono::duration_cast<std::chrono::microseconds>(
                               std::chrono::steady_clock::now().time_since_epoch())
                               .count();
    hand_pointing.update(*participant, snapshot, &surfaces, in, now_us);
    own_color = participant_color(snapshot.id);
  }

  // The left controller's voice buttons: talk held, mute pressed, the thumbstick's volume steps
  // for the voice looked at (xr_controllers.hpp, voice_controls.hpp).
  void track_voice_buttons(const ControllerState& left, const SessionSnapshot& snapshot,
                           int64_t now) {
    voice::VoiceLink* link = o.voice ? o.voice() : nullptr;
    if (!link) return;  // no voice link (or not yet)
    const bool was_muted = link->muted();
    press_voice_buttons(voice_input, voice_buttons, {left.talk, left.mute});
    // The volumes now are read (stats(), voice_rows: allocations) only on a push's first frame.
    if (std::abs(left.volume) < voice::kVolumeRest) {
      volume_gesture.pushed = false;
    } else if (!volume_gesture.pushed && std::abs(left.volume) >= voice::kVolumePush) {
      const voice::VoiceStats stats = link->stats();
      const auto rows = voice::voice_rows(snapshot, &stats, link->config().volumes, now);
      if (const uint32_t id = voice::step_volume(volume_gesture, voice_input, snapshot, rows,
                                                 left.volume, link->config().site_position, now))
        spdlog::info("voice: participant {} at {:.0f} %", id, volume_gesture.shown_gain * 100);
    }
    apply_voice_input(*link, voice_input);
    if (link->muted() != was_muted)
      spdlog::info("voice: microphone {}", link->muted() ? "muted" : "on");
  }

  // Draws each located eye (the SessionScene with a participant, else the cameras) and fills
  // `layer` with them.
  void draw_eyes(XrCompositionLayerProjection& layer, int64_t now) {
    // The head between the eyes (their mean position, the first eye's orientation): what stays
    // fixed in view is placed from it, the same for both eyes.
    RigidTransform world_from_head = world_from_stage_now * rigid_from_xr(views[0].pose);
    if (rig.view_count > 1)
      world_from_head.translation =
          0.5 * (world_from_head.translation +
                 (world_from_stage_now * rigid_from_xr(views[1].pose)).translation);
    for (uint32_t i = 0; i < rig.view_count; ++i) {
      const View view =
          xr_eye_view(world_from_stage_now, views[i].pose, views[i].fov, o.near_m, o.far_m);
      xr::draw_eye(rig.eyes[i], [&](const RenderTarget& target) {
        if (participant) {
          SessionSceneOptions so = o.scene;
          so.pass = pass;
          const voice::VoiceLink* link = o.voice ? o.voice() : nullptr;
          so.own_muted = link && link->muted();  // a red ball over the left hand
          so.world_from_head = world_from_head;  // a red ball in view while recorded
          if (link && now < volume_gesture.shown_until_us)
            so.volume_shown = SessionSceneOptions::VolumeShown{volume_gesture.shown_at,
                                                               volume_gesture.shown_gain};
          scene->draw(view, target, cameras, uploaded, *participant, now, so);
          if (hand_pointing.stroke().size() >= 2) {  // the stroke being drawn
            session::Annotation drawn;
            drawn.points = hand_pointing.stroke();
            scene->draw_primitives(view, target, annotation_primitives(drawn, own_color));
          }
        } else {
          renderer.draw_cameras(view, target, pass);
        }
      });
      projected[i] =
          xr_struct<XrCompositionLayerProjectionView>(XR_TYPE_COMPOSITION_LAYER_PROJECTION_VIEW);
      projected[i].pose = views[i].pose;
      projected[i].fov = views[i].fov;
      projected[i].subImage.swapchain = rig.eyes[i].swapchain.handle;
      projected[i].subImage.imageRect.extent = {rig.eyes[i].width, rig.eyes[i].height};
    }
    layer.space = rig.space.handle;
    layer.viewCount = rig.view_count;
    layer.views = projected.data();
  }

  // One frame of a running session: waits for the runtime's frame and begins it; where it is to
  // be rendered and the eyes are located, tracks the participant and draws the eyes; ends it
  // with one projection layer, or none. True if the layer was submitted.
  bool render_frame() {
    XrSession session = rig.session.handle;
    auto frame = xr_struct<XrFrameState>(XR_TYPE_FRAME_STATE);
    xr_check_live(xrWaitFrame(session, nullptr, &frame), "xrWaitFrame");
    keep_budget(frame);
    xr_check_live(xrBeginFrame(session, nullptr), "xrBeginFrame");
    auto layer = xr_struct<XrCompositionLayerProjection>(XR_TYPE_COMPOSITION_LAYER_PROJECTION);
    const XrCompositionLayerBaseHeader* layers[] = {
        reinterpret_cast<const XrCompositionLayerBaseHeader*>(&layer)};
    uint32_t layer_count = 0;
    if (frame.shouldRender) {
      auto locate = xr_struct<XrViewLocateInfo>(XR_TYPE_VIEW_LOCATE_INFO);
      locate.viewConfigurationType = kStereo;
      locate.displayTime = frame.predictedDisplayTime;
      locate.space = rig.space.handle;
      auto state = xr_struct<XrViewState>(XR_TYPE_VIEW_STATE);
      uint32_t located = 0;
      xr_check_live(xrLocateViews(session, &locate, &state, rig.view_count, &located, views.data()),
                    "xrLocateViews");
      if ((state.viewStateFlags & XR_VIEW_STATE_ORIENTATION_VALID_BIT) &&
          located == rig.view_count) {
        const int64_t now = wall_clock_us();
        if (participant && rig.view_count > 0) track_participant(frame, now);
        draw_eyes(layer, now);
        layer_count = 1;
        last_blended = pass.blend && started;
      }
    }
    auto end = xr_struct<XrFrameEndInfo>(XR_TYPE_FRAME_END_INFO);
    end.displayTime = frame.predictedDisplayTime;
    end.environmentBlendMode = XR_ENVIRONMENT_BLEND_MODE_OPAQUE;
    end.layerCount = layer_count;
    end.layers = layers;
    xr_check_live(xrEndFrame(session, &end), "xrEndFrame");
    return layer_count > 0;
  }
};

void present(FrameFeed& feed, ViewerResult& result, const XrOptions& o) {
  HiddenContext context;
  CameraRenderer renderer;
  Participant* participant = o.participant ? o.participant() : nullptr;
  std::unique_ptr<SessionScene> scene;
  if (participant) scene = std::make_unique<SessionScene>();
  result.renderer = renderer.gl_description();
  const std::vector<CameraCalibration>& cameras = feed.cameras();
  renderer.set_cameras(cameras);
  renderer.set_avatar_filter(o.avatar_filter);

  XrRig rig;
  xr::open_rig(rig, context.window, o);
  spdlog::info("OpenXR: {} eyes of {}x{}, {} space, {}", rig.view_count,
               rig.view_count ? rig.eyes[0].width : 0, rig.view_count ? rig.eyes[0].height : 0,
               rig.eye_height > 0 ? "STAGE" : "LOCAL", result.renderer);

  XrControllers controllers(rig.instance.handle, rig.session.handle);
  FrameLoop loop(o, rig, renderer, scene.get(), participant, controllers, cameras);
  try {
    while (!feed.finished()) {
      glfwPollEvents();
      if (!xr::poll_events(rig.instance.handle, rig.session.handle, loop.running)) break;
      loop.take_frames(feed);
      if (!loop.running) continue;
      if (loop.render_frame() && loop.started) {
        ++result.frames_rendered;
        feed.presented();  // the frame was submitted (xrEndFrame) with the newest images
      }
    }
  } catch (const Lost&) {
    spdlog::warn("OpenXR: the runtime lost the session");
  }
  result.blend_off = loop.blend_off;
  feed.close();  // the headset's session ended (or the stream did, when this changes nothing)
}

}  // namespace

Presenter xr_presenter(const XrOptions& options) {
  return [options](FrameFeed& feed, ViewerResult& result) { present(feed, result, options); };
}

}  // namespace volcast
