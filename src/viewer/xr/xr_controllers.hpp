#pragma once
// The headset's two controllers through OpenXR actions (internal to volcast_viewer_xr): a grip
// pose and a squeeze value per hand, with suggested bindings for Oculus Touch (grip/pose,
// squeeze/value), Valve Index (grip/pose, squeeze/value), HTC Vive (grip/pose, squeeze/click) and
// the KHR simple controller (grip/pose, select/click); the runtime picks the profile of the
// device. A runtime without actions leaves the controllers untracked (logged once).
#include <openxr/openxr.h>

#include <array>

#include "volcast/session/room.hpp"

namespace volcast {

/// One hand this frame, in the space located against (metres; OpenXR grip: palm centre, -z
/// along the pointing direction).
struct ControllerState {
  bool tracked = false;
  Pose pose;
  float squeeze = 0;  ///< 0..1
};

class XrControllers {
 public:
  /// Creates the action set, actions, bindings and grip spaces and attaches them to `session`
  /// (before the session's first xrSyncActions). Never throws: without actions, disabled.
  XrControllers(XrInstance instance, XrSession session);
  ~XrControllers();
  XrControllers(const XrControllers&) = delete;
  XrControllers& operator=(const XrControllers&) = delete;
  /// Syncs the actions and locates both grips in `space` at `time` (left, right).
  std::array<ControllerState, 2> sync(XrSpace space, XrTime time);

 private:
  XrSession session_ = XR_NULL_HANDLE;
  XrActionSet set_ = XR_NULL_HANDLE;
  XrAction grip_ = XR_NULL_HANDLE, squeeze_ = XR_NULL_HANDLE;
  std::array<XrPath, 2> hands_{};
  std::array<XrSpace, 2> spaces_{};
  bool enabled_ = false;
};

}  // namespace volcast
