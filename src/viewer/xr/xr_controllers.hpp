#pragma once
// The headset's two controllers through OpenXR actions (internal to volcast_viewer_xr): a grip
// pose and a squeeze value per hand, with suggested bindings for Oculus Touch (grip/pose,
// squeeze/value), Valve Index (grip/pose, squeeze/value), HTC Vive (grip/pose, squeeze/click) and
// the KHR simple controller (grip/pose, select/click); the runtime picks the profile of the
// device. A runtime without actions leaves the controllers untracked (logged once).
//
// The voice buttons (issue 35), on the left controller only:
//   profile      talk (hold, push-to-talk)   mute (press toggles)
//   Touch        X        x/click            Y     y/click
//   Index        A        a/click            B     b/click
//   Vive         trackpad trackpad/click     menu  menu/click
//   simple       --                          menu  menu/click
//
// The laser pointer, drawing and labels (issue 36) on the right controller, erasing on the left,
// as in the browser's headset mode: the ray is the right hand's OpenXR aim pose (from its position
// along its -z); a label press pins the preset the right thumbstick leans to (hand_pointing.hpp).
//   profile      point (hold)        draw a stroke (hold)     pin a label        erase your newest
//   Touch        A  a/click          B  b/click               right thumbstick   left thumbstick
//   Index        A  a/click          B  b/click               right thumbstick   left thumbstick
//   Vive         trigger/click       trackpad/click           --                 right menu/click
//   simple       menu/click          --                       --                 --
// (a thumbstick pressed: thumbstick/click; the label's lean: the right thumbstick/x, /y)
#include <openxr/openxr.h>

#include <array>

#include "volcast/room/room.hpp"

namespace volcast {

/// One hand this frame, in the space located against (metres; OpenXR grip: palm centre, -z
/// along the pointing direction).
struct ControllerState {
  bool tracked = false;
  Pose pose;
  float squeeze = 0;  ///< 0..1
  bool talk = false;  ///< the talk button is held (left hand only; read even when not located)
  bool mute = false;  ///< the mute button is held (left hand only)
  /// The left thumbstick's (Vive: trackpad's) y, -1 down to 1 up: steps the volume of the voice
  /// looked at (voice::step_volume). Left hand only; 0 where the profile has none.
  float volume = 0;
  /// The right hand's aim pose (OpenXR: the pointing ray from its position along its -z), located
  /// as `pose` is; aim_tracked false where it could not be located. Right hand only.
  bool aim_tracked = false;
  Pose aim;
  bool point = false;  ///< the point button is held (right hand only)
  bool draw = false;   ///< the draw button is held (right hand only)
  bool label = false;  ///< the label button is held (right hand only)
  /// Where the right thumbstick leans (x right, y up, -1..1), which picks the label's preset.
  Eigen::Vector2f label_stick = Eigen::Vector2f::Zero();
  bool erase = false;  ///< the erase button is held (reported on the left hand)
};

class XrControllers {
 public:
  /// Creates the action set, actions, bindings and grip spaces and attaches them to `session`
  /// (before the session's first xrSyncActions). Never throws: without actions, disabled.
  XrControllers(XrInstance instance, XrSession session);
  ~XrControllers();
  XrControllers(const XrControllers&) = delete;
  XrControllers& operator=(const XrControllers&) = delete;
  /// Syncs the actions, reads the buttons and locates both grips in `space` at `time` (left,
  /// right). All released while the session is not focused.
  std::array<ControllerState, 2> sync(XrSpace space, XrTime time);

 private:
  /// Locates `action_space` in `space` at `time` into `pose`; false where it is not valid.
  static bool locate(XrSpace action_space, XrSpace space, XrTime time, Pose& pose);
  XrSession session_ = XR_NULL_HANDLE;
  XrActionSet set_ = XR_NULL_HANDLE;
  XrAction grip_ = XR_NULL_HANDLE, squeeze_ = XR_NULL_HANDLE, talk_ = XR_NULL_HANDLE,
           mute_ = XR_NULL_HANDLE, volume_ = XR_NULL_HANDLE, aim_ = XR_NULL_HANDLE,
           point_ = XR_NULL_HANDLE, draw_ = XR_NULL_HANDLE, label_ = XR_NULL_HANDLE,
           label_x_ = XR_NULL_HANDLE, label_y_ = XR_NULL_HANDLE, erase_ = XR_NULL_HANDLE;
  std::array<XrPath, 2> hands_{};
  std::array<XrSpace, 2> spaces_{};
  XrSpace aim_space_ = XR_NULL_HANDLE;  // the right hand's aim pose
  bool enabled_ = false;
};

}  // namespace volcast
