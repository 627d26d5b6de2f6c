// The OpenXR presenter: instance, session bound to a hidden GLFW window's GLX context, stereo
// swapchains with an FBO each, and the frame loop.
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
#include "volcast/pipeline/viewer_result.hpp"
#include "volcast/render/annotation_scene.hpp"
#include "volcast/viewer/xr.hpp"
#include "volcast/viewer/xr_view.hpp"
#include "volcast/voice/voice_controls.hpp"
#include "xr_common.hpp"
#include "xr_controllers.hpp"

// Platform headers last: Xlib's macros (None, Success, Status, ...) would break Eigen above.
#include <X11/Xlib.h>
#include <epoxy/gl.h>
#include <epoxy/glx.h>
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#define GLFW_EXPOSE_NATIVE_X11
#define GLFW_EXPOSE_NATIVE_GLX
#include <GLFW/glfw3native.h>  // glfwGetX11Display, glfwGetGLXContext, glfwGetGLXWindow
#define XR_USE_PLATFORM_XLIB
#define XR_USE_GRAPHICS_API_OPENGL
#include <openxr/openxr_platform.h>

namespace volcast {
namespace {

// glfwInit() .. glfwTerminate() and a hidden window whose OpenGL 4.5 core context (GLX) is
// current on this thread: the context the session renders with.
struct HiddenContext {
  GLFWwindow* window = nullptr;
  HiddenContext() {
    if (!glfwInit()) throw Error("OpenXR needs an X display for its OpenGL context (GLX)");
    glfwWindowHint(GLFW_VISIBLE, GLFW_FALSE);
    glfwWindowHint(GLFW_CONTEXT_CREATION_API, GLFW_NATIVE_CONTEXT_API);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 4);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 5);
    glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
    window = glfwCreateWindow(64, 64, "volcast (OpenXR)", nullptr, nullptr);
    if (!window) {
      glfwTerminate();
      throw Error("OpenXR: cannot make an OpenGL 4.5 core context (GLX) for the session");
    }
    glfwMakeContextCurrent(window);
    glfwSwapInterval(0);  // the runtime paces frames (xrWaitFrame)
  }
  ~HiddenContext() {
    glfwDestroyWindow(window);
    glfwTerminate();
  }
  HiddenContext(const HiddenContext&) = delete;
  HiddenContext& operator=(const HiddenContext&) = delete;
};

// An OpenXR handle destroyed with its function.
template <typename Handle, XrResult (*destroy)(Handle)>
struct XrHandle {
  Handle handle = XR_NULL_HANDLE;
  XrHandle() = default;
  ~XrHandle() {
    if (handle != XR_NULL_HANDLE) destroy(handle);
  }
  XrHandle(const XrHandle&) = delete;
  XrHandle& operator=(const XrHandle&) = delete;
};
using Instance = XrHandle<XrInstance, xrDestroyInstance>;
using Session = XrHandle<XrSession, xrDestroySession>;
using Space = XrHandle<XrSpace, xrDestroySpace>;
using Swapchain = XrHandle<XrSwapchain, xrDestroySwapchain>;

// The runtime lost the instance or the session (XR_ERROR_INSTANCE_LOST, XR_ERROR_SESSION_LOST, with
// or without a loss pending event before): the viewer's session ends as closed, not on an error.
struct Lost {};

// xr_check for the calls of a running session: throws Lost for a lost instance or session.
XrResult xr_check_live(XrResult result, const char* call) {
  if (result == XR_ERROR_INSTANCE_LOST || result == XR_ERROR_SESSION_LOST) throw Lost{};
  return xr_check(result, call);
}

// One eye: its swapchain, the swapchain's images, and an FBO with a depth renderbuffer that each
// acquired image is attached to.
struct Eye {
  Swapchain swapchain;
  std::vector<XrSwapchainImageOpenGLKHR> images;
  int width = 0, height = 0;
  GLuint framebuffer = 0, depth = 0;
  ~Eye() {
    glDeleteFramebuffers(1, &framebuffer);
    glDeleteRenderbuffers(1, &depth);
  }
};

XrGraphicsBindingOpenGLXlibKHR glx_binding(GLFWwindow* window) {
  auto binding =
      xr_struct<XrGraphicsBindingOpenGLXlibKHR>(XR_TYPE_GRAPHICS_BINDING_OPENGL_XLIB_KHR);
  binding.xDisplay = glfwGetX11Display();
  binding.glxContext = glfwGetGLXContext(window);
  binding.glxDrawable = glfwGetGLXWindow(window);
  int id = 0;
  glXQueryContext(binding.xDisplay, binding.glxContext, GLX_FBCONFIG_ID, &id);
  const int attributes[] = {GLX_FBCONFIG_ID, id, None};
  int count = 0;
  GLXFBConfig* configs =
      glXChooseFBConfig(binding.xDisplay, DefaultScreen(binding.xDisplay), attributes, &count);
  if (configs && count > 0) {
    binding.glxFBConfig = configs[0];
    if (XVisualInfo* visual = glXGetVisualFromFBConfig(binding.xDisplay, configs[0])) {
      binding.visualid = static_cast<uint32_t>(visual->visualid);
      XFree(visual);
    }
  }
  if (configs) XFree(configs);
  return binding;
}

// GL_SRGB8_ALPHA8 where offered (our colors are sRGB-encoded already and GL_FRAMEBUFFER_SRGB stays
// off, so they are stored as they are and shown right), else GL_RGBA8, else the runtime's first.
int64_t pick_format(XrSession session) {
  uint32_t count = 0;
  xr_check(xrEnumerateSwapchainFormats(session, 0, &count, nullptr), "xrEnumerateSwapchainFormats");
  std::vector<int64_t> formats(count);
  xr_check(xrEnumerateSwapchainFormats(session, count, &count, formats.data()),
           "xrEnumerateSwapchainFormats");
  for (const int64_t wanted : {int64_t{GL_SRGB8_ALPHA8}, int64_t{GL_RGBA8}})
    if (std::find(formats.begin(), formats.end(), wanted) != formats.end()) return wanted;
  if (formats.empty()) throw Error("OpenXR: the runtime offers no swapchain format");
  return formats.front();
}

XrReferenceSpaceType pick_space(XrSession session) {
  uint32_t count = 0;
  xr_check(xrEnumerateReferenceSpaces(session, 0, &count, nullptr), "xrEnumerateReferenceSpaces");
  std::vector<XrReferenceSpaceType> spaces(count);
  xr_check(xrEnumerateReferenceSpaces(session, count, &count, spaces.data()),
           "xrEnumerateReferenceSpaces");
  return std::find(spaces.begin(), spaces.end(), XR_REFERENCE_SPACE_TYPE_STAGE) != spaces.end()
             ? XR_REFERENCE_SPACE_TYPE_STAGE
             : XR_REFERENCE_SPACE_TYPE_LOCAL;
}

void make_eye(XrSession session, const XrViewConfigurationView& config, int64_t format, Eye& eye) {
  eye.width = static_cast<int>(config.recommendedImageRectWidth);
  eye.height = static_cast<int>(config.recommendedImageRectHeight);
  auto info = xr_struct<XrSwapchainCreateInfo>(XR_TYPE_SWAPCHAIN_CREATE_INFO);
  info.usageFlags = XR_SWAPCHAIN_USAGE_COLOR_ATTACHMENT_BIT | XR_SWAPCHAIN_USAGE_SAMPLED_BIT;
  info.format = format;
  info.sampleCount = 1;
  info.width = config.recommendedImageRectWidth;
  info.height = config.recommendedImageRectHeight;
  info.faceCount = info.arraySize = info.mipCount = 1;
  xr_check(xrCreateSwapchain(session, &info, &eye.swapchain.handle), "xrCreateSwapchain");
  uint32_t count = 0;
  xr_check(xrEnumerateSwapchainImages(eye.swapchain.handle, 0, &count, nullptr),
           "xrEnumerateSwapchainImages");
  eye.images.assign(count,
                    xr_struct<XrSwapchainImageOpenGLKHR>(XR_TYPE_SWAPCHAIN_IMAGE_OPENGL_KHR));
  xr_check(
      xrEnumerateSwapchainImages(eye.swapchain.handle, count, &count,
                                 reinterpret_cast<XrSwapchainImageBaseHeader*>(eye.images.data())),
      "xrEnumerateSwapchainImages");
  glCreateRenderbuffers(1, &eye.depth);
  glNamedRenderbufferStorage(eye.depth, GL_DEPTH_COMPONENT24, eye.width, eye.height);
  glCreateFramebuffers(1, &eye.framebuffer);
  glNamedFramebufferRenderbuffer(eye.framebuffer, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, eye.depth);
}

// Draws `view` into the eye's next swapchain image.
void draw_eye(Eye& eye, const std::function<void(const RenderTarget&)>& draw) {
  uint32_t index = 0;
  xr_check_live(xrAcquireSwapchainImage(eye.swapchain.handle, nullptr, &index),
                "xrAcquireSwapchainImage");
  auto wait = xr_struct<XrSwapchainImageWaitInfo>(XR_TYPE_SWAPCHAIN_IMAGE_WAIT_INFO);
  wait.timeout = XR_INFINITE_DURATION;
  xr_check_live(xrWaitSwapchainImage(eye.swapchain.handle, &wait), "xrWaitSwapchainImage");
  glNamedFramebufferTexture(eye.framebuffer, GL_COLOR_ATTACHMENT0, eye.images[index].image, 0);
  draw(RenderTarget{eye.framebuffer, 0, 0, eye.width, eye.height});
  xr_check_live(xrReleaseSwapchainImage(eye.swapchain.handle, nullptr), "xrReleaseSwapchainImage");
}

// Handles the pending events; false once the viewer should end (exiting, loss pending). A lost
// instance throws Lost.
bool poll_events(XrInstance instance, XrSession session, bool& running) {
  for (;;) {
    auto event = xr_struct<XrEventDataBuffer>(XR_TYPE_EVENT_DATA_BUFFER);
    if (xr_check_live(xrPollEvent(instance, &event), "xrPollEvent") == XR_EVENT_UNAVAILABLE)
      return true;
    if (event.type == XR_TYPE_EVENT_DATA_INSTANCE_LOSS_PENDING) return false;
    if (event.type == XR_TYPE_EVENT_DATA_SESSION_STATE_CHANGED) {
      const auto& changed = reinterpret_cast<const XrEventDataSessionStateChanged&>(event);
      switch (changed.state) {
        case XR_SESSION_STATE_READY: {
          auto begin = xr_struct<XrSessionBeginInfo>(XR_TYPE_SESSION_BEGIN_INFO);
          begin.primaryViewConfigurationType = XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO;
          xr_check_live(xrBeginSession(session, &begin), "xrBeginSession");
          running = true;
          spdlog::info("OpenXR: session running");
          break;
        }
        case XR_SESSION_STATE_STOPPING:
          xr_check_live(xrEndSession(session), "xrEndSession");
          running = false;
          break;
        case XR_SESSION_STATE_EXITING:
        case XR_SESSION_STATE_LOSS_PENDING:
          return false;
        default:
          break;
      }
    }
  }
}

// The OpenXR objects of the presenter, made in this order (open_instance, open_session,
// make_eyes) and destroyed in reverse: the instance and its head-mounted system, the session bound
// to the hidden window's GLX context, its reference space (STAGE where offered, else LOCAL) and
// one Eye per view of the stereo configuration.
struct XrRig {
  Instance instance;
  XrSystemId system = XR_NULL_SYSTEM_ID;
  Session session;
  Space space;
  float eye_height = 0;  // STAGE: XrOptions::eye_height_m (its floor is at 0); LOCAL: 0
  uint32_t view_count = 0;
  std::vector<Eye> eyes;
};

constexpr auto kStereo = XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO;

// The instance with XR_KHR_opengl_enable and its head-mounted display; checks the runtime's
// OpenGL requirements (which OpenXR requires asking for before xrCreateSession).
void open_instance(XrRig& rig) {
  xr_check(create_gl_instance(&rig.instance.handle), "xrCreateInstance");
  auto system_info = xr_struct<XrSystemGetInfo>(XR_TYPE_SYSTEM_GET_INFO);
  system_info.formFactor = XR_FORM_FACTOR_HEAD_MOUNTED_DISPLAY;
  xr_check(xrGetSystem(rig.instance.handle, &system_info, &rig.system), "xrGetSystem");
  PFN_xrGetOpenGLGraphicsRequirementsKHR requirements_of = nullptr;
  xr_check(xrGetInstanceProcAddr(rig.instance.handle, "xrGetOpenGLGraphicsRequirementsKHR",
                                 reinterpret_cast<PFN_xrVoidFunction*>(&requirements_of)),
           "xrGetInstanceProcAddr(xrGetOpenGLGraphicsRequirementsKHR)");
  auto requirements =
      xr_struct<XrGraphicsRequirementsOpenGLKHR>(XR_TYPE_GRAPHICS_REQUIREMENTS_OPENGL_KHR);
  xr_check(requirements_of(rig.instance.handle, rig.system, &requirements),
           "xrGetOpenGLGraphicsRequirementsKHR");  // required before xrCreateSession
  if (requirements.minApiVersionSupported > XR_MAKE_VERSION(4, 5, 0))
    throw Error("OpenXR: the runtime needs a newer OpenGL than 4.5");
}

// The session on `window`'s GLX context and its reference space.
void open_session(XrRig& rig, GLFWwindow* window, const XrOptions& o) {
  const XrGraphicsBindingOpenGLXlibKHR binding = glx_binding(window);
  auto session_info = xr_struct<XrSessionCreateInfo>(XR_TYPE_SESSION_CREATE_INFO);
  session_info.next = &binding;
  session_info.systemId = rig.system;
  xr_check(xrCreateSession(rig.instance.handle, &session_info, &rig.session.handle),
           "xrCreateSession");
  auto space_info = xr_struct<XrReferenceSpaceCreateInfo>(XR_TYPE_REFERENCE_SPACE_CREATE_INFO);
  space_info.referenceSpaceType = pick_space(rig.session.handle);
  space_info.poseInReferenceSpace.orientation.w = 1;
  xr_check(xrCreateReferenceSpace(rig.session.handle, &space_info, &rig.space.handle),
           "xrCreateReferenceSpace");
  rig.eye_height =
      space_info.referenceSpaceType == XR_REFERENCE_SPACE_TYPE_STAGE ? o.eye_height_m : 0;
}

// One eye per view of the stereo configuration, at the runtime's recommended size.
void make_eyes(XrRig& rig) {
  xr_check(xrEnumerateViewConfigurationViews(rig.instance.handle, rig.system, kStereo, 0,
                                             &rig.view_count, nullptr),
           "xrEnumerateViewConfigurationViews");
  std::vector<XrViewConfigurationView> configs(
      rig.view_count, xr_struct<XrViewConfigurationView>(XR_TYPE_VIEW_CONFIGURATION_VIEW));
  xr_check(xrEnumerateViewConfigurationViews(rig.instance.handle, rig.system, kStereo,
                                             rig.view_count, &rig.view_count, configs.data()),
           "xrEnumerateViewConfigurationViews");
  const int64_t format = pick_format(rig.session.handle);
  rig.eyes = std::vector<Eye>(rig.view_count);
  for (uint32_t i = 0; i < rig.view_count; ++i)
    make_eye(rig.session.handle, configs[i], format, rig.eyes[i]);
}

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
    for (size_t i = 0; i < frames.size() && i < uploaded.size(); ++i)
      if (frames[i] && frames[i] != uploaded[i]) {
        renderer.upload(i, *frames[i]);
        uploaded[i] = frames[i];
        surfaces_stale = true;
      }
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
    for (uint32_t i = 0; i < rig.view_count; ++i) {
      const View view =
          xr_eye_view(world_from_stage_now, views[i].pose, views[i].fov, o.near_m, o.far_m);
      draw_eye(rig.eyes[i], [&](const RenderTarget& target) {
        if (participant) {
          SessionSceneOptions so = o.scene;
          so.pass = pass;
          const voice::VoiceLink* link = o.voice ? o.voice() : nullptr;
          so.own_muted = link && link->muted();  // a red ball over the left hand
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
  open_instance(rig);
  open_session(rig, context.window, o);
  make_eyes(rig);
  spdlog::info("OpenXR: {} eyes of {}x{}, {} space, {}", rig.view_count,
               rig.view_count ? rig.eyes[0].width : 0, rig.view_count ? rig.eyes[0].height : 0,
               rig.eye_height > 0 ? "STAGE" : "LOCAL", result.renderer);

  XrControllers controllers(rig.instance.handle, rig.session.handle);
  FrameLoop loop(o, rig, renderer, scene.get(), participant, controllers, cameras);
  try {
    while (!feed.finished()) {
      glfwPollEvents();
      if (!poll_events(rig.instance.handle, rig.session.handle, loop.running)) break;
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
