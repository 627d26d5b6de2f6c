#pragma once
// The VR viewer through OpenXR (Debian's loader, libopenxr-dev): a session on the head-mounted
// display with XR_KHR_opengl_enable, bound to the OpenGL 4.5 context of a hidden GLFW window
// (GLX); one swapchain per eye (GL_SRGB8_ALPHA8 where the runtime offers it, else RGBA8), each
// image attached to an FBO with a depth renderbuffer, drawn by CameraRenderer from that eye's View
// (xr_view.hpp: the located eye pose and its asymmetric field of view) and submitted as one
// projection layer in a STAGE reference space (LOCAL where there is no STAGE). It is a Presenter
// (volcast/pipeline/frame_feed.hpp). The session's state drives it: READY begins it, STOPPING ends
// it, EXITING, LOSS_PENDING or a lost instance end the viewer's session (FrameFeed::close()).
#include <functional>
#include <optional>
#include <string>

#include "volcast/pipeline/frame_feed.hpp"
#include "volcast/pipeline/session_scene.hpp"
#include "volcast/reconstruct/avatar_filter.hpp"
#include "volcast/render/camera_renderer.hpp"
#include "volcast/render/frame_budget.hpp"
#include "volcast/render/view.hpp"
#include "volcast/voice/voice_link.hpp"

namespace volcast {

struct XrOptions {
  CameraPassOptions pass;
  /// kAuto: blending (pass.blend) goes off for the session once the runtime's display times come
  /// more than 1.5 display periods apart (FrameBudget, with the runtime's predictedDisplayPeriod);
  /// result.blend_off says why. kOn: never turned off. kOff: pass.blend starts off.
  BlendPolicy blend = BlendPolicy::kAuto;
  AvatarFilter avatar_filter;
  /// What the user sees when standing at the stage's origin (world_from_stage()); default:
  /// default_view() of the first frames.
  std::optional<ViewCamera> view;
  float eye_height_m = 1.6f;  ///< assumed eye height above a STAGE space's floor (0 for LOCAL)
  float near_m = 0.05f, far_m = 100;
  /// A participant of a virtual-OR session (volcast view --xr --join), or empty: a plain viewer.
  /// With one, each eye draws the SessionScene; the STAGE space is the participant's play area
  /// (world_from_stage = room_from_playarea of its spot, following its teleports; a LOCAL space
  /// is lifted by eye_height_m) and the head (the eyes' midpoint, the first eye's orientation)
  /// is published as its pose every frame, both controllers' grips as its hands (OpenXR actions:
  /// Touch, Index, Vive or the KHR simple controller); squeezing a grip within reach of one of
  /// the case's objects grabs it, and it follows the hand until the grip is let go (hand_grab.hpp).
  /// The right controller is a laser pointer (hand_pointing.hpp, buttons in xr_controllers.hpp:
  /// A held on Touch and Index): everyone sees it, its dot where its aim ray meets the live clouds
  /// (the site cameras' newest depth); B held draws a stroke there, sent when B is let go.
  std::function<Participant*()> participant;
  SessionSceneOptions scene;
  /// With a participant: its voice link (volcast view --xr --join --mic/--speaker), read every
  /// frame; empty, or returning null (no link, or not made yet): the buttons do nothing. The link
  /// must outlive the presenter. The left controller's talk button is held to talk with
  /// push-to-talk, each press of its mute button mutes or unmutes (X and Y on Touch; the table in
  /// xr_controllers.hpp); while muted, a small red ball shows over the left hand.
  std::function<voice::VoiceLink*()> voice;
};

/// Whether OpenXR can run here: an instance with XR_KHR_opengl_enable can be made (a runtime is
/// installed and active) and it has a head-mounted display. On false, `why` (if not null) is one
/// phrase naming the result, e.g. "no runtime available (XR_ERROR_RUNTIME_UNAVAILABLE)" or "no
/// headset (XR_ERROR_FORM_FACTOR_UNAVAILABLE)". Throws nothing.
bool xr_available(std::string* why);

/// The VR viewer as a Presenter. It throws Error naming the OpenXR call and its result (ending
/// the session with ViewerEnd::kError) if a step fails, e.g. no display for the GLFW context.
Presenter xr_presenter(const XrOptions& options);

}  // namespace volcast
