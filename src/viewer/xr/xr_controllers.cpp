#include "xr_controllers.hpp"

#include <spdlog/spdlog.h>

#include <cstring>
#include <string>
#include <vector>

#include "volcast/core/error.hpp"
#include "xr_common.hpp"

namespace volcast {

XrControllers::XrControllers(XrInstance instance, XrSession session) : session_(session) {
  try {
    const auto path = [&](const char* s) {
      XrPath p = XR_NULL_PATH;
      xr_check(xrStringToPath(instance, s, &p), "xrStringToPath");
      return p;
    };
    hands_ = {path("/user/hand/left"), path("/user/hand/right")};
    auto set_info = xr_struct<XrActionSetCreateInfo>(XR_TYPE_ACTION_SET_CREATE_INFO);
    std::strcpy(set_info.actionSetName, "volcast");
    std::strcpy(set_info.localizedActionSetName, "Volcast");
    xr_check(xrCreateActionSet(instance, &set_info, &set_), "xrCreateActionSet");
    const auto action = [&](const char* name, const char* label, XrActionType type) {
      auto info = xr_struct<XrActionCreateInfo>(XR_TYPE_ACTION_CREATE_INFO);
      std::strcpy(info.actionName, name);
      std::strcpy(info.localizedActionName, label);
      info.actionType = type;
      info.countSubactionPaths = 2;
      info.subactionPaths = hands_.data();
      XrAction a = XR_NULL_HANDLE;
      xr_check(xrCreateAction(set_, &info, &a), "xrCreateAction");
      return a;
    };
    grip_ = action("grip", "Hand pose", XR_ACTION_TYPE_POSE_INPUT);
    squeeze_ = action("squeeze", "Grab", XR_ACTION_TYPE_FLOAT_INPUT);
    talk_ = action("talk", "Push to talk", XR_ACTION_TYPE_BOOLEAN_INPUT);
    mute_ = action("mute", "Mute microphone", XR_ACTION_TYPE_BOOLEAN_INPUT);
    volume_ = action("volume", "Volume of the voice looked at", XR_ACTION_TYPE_FLOAT_INPUT);
    aim_ = action("aim", "Laser pointer ray", XR_ACTION_TYPE_POSE_INPUT);
    point_ = action("point", "Laser pointer", XR_ACTION_TYPE_BOOLEAN_INPUT);
    draw_ = action("draw", "Draw a stroke", XR_ACTION_TYPE_BOOLEAN_INPUT);
    label_ = action("label", "Pin a label", XR_ACTION_TYPE_BOOLEAN_INPUT);
    label_x_ = action("label_x", "Label choice (across)", XR_ACTION_TYPE_FLOAT_INPUT);
    label_y_ = action("label_y", "Label choice (up)", XR_ACTION_TYPE_FLOAT_INPUT);
    erase_ = action("erase", "Erase your newest annotation", XR_ACTION_TYPE_BOOLEAN_INPUT);
    // The voice buttons and erasing are the left controller's, pointing, drawing and labels the
    // right one's (null: the profile has none to spare). The label's stick is "thumbstick".
    const struct {
      const char* profile;
      const char* squeeze;
      const char* talk;
      const char* mute;
      const char* volume;
      const char* point;
      const char* draw;
      const char* label;  // right hand
      const char* erase;  // left hand (Vive: right)
    } profiles[] = {
        {"/interaction_profiles/khr/simple_controller", "select/click", nullptr, "menu/click",
         nullptr, "menu/click", nullptr, nullptr, nullptr},
        {"/interaction_profiles/htc/vive_controller", "squeeze/click", "trackpad/click",
         "menu/click", "trackpad/y", "trigger/click", "trackpad/click", nullptr, "menu/click"},
        {"/interaction_profiles/valve/index_controller", "squeeze/value", "a/click", "b/click",
         "thumbstick/y", "a/click", "b/click", "thumbstick/click", "thumbstick/click"},
        {"/interaction_profiles/oculus/touch_controller", "squeeze/value", "x/click", "y/click",
         "thumbstick/y", "a/click", "b/click", "thumbstick/click", "thumbstick/click"}};
    for (const auto& p : profiles) {
      std::vector<XrActionSuggestedBinding> bindings;
      for (const char* hand : {"left", "right"}) {
        bindings.push_back(
            {grip_, path(("/user/hand/" + std::string(hand) + "/input/grip/pose").c_str())});
        bindings.push_back(
            {squeeze_, path(("/user/hand/" + std::string(hand) + "/input/" + p.squeeze).c_str())});
      }
      if (p.talk)
        bindings.push_back({talk_, path(("/user/hand/left/input/" + std::string(p.talk)).c_str())});
      if (p.mute)
        bindings.push_back({mute_, path(("/user/hand/left/input/" + std::string(p.mute)).c_str())});
      if (p.volume)
        bindings.push_back(
            {volume_, path(("/user/hand/left/input/" + std::string(p.volume)).c_str())});
      bindings.push_back({aim_, path("/user/hand/right/input/aim/pose")});
      if (p.point)
        bindings.push_back(
            {point_, path(("/user/hand/right/input/" + std::string(p.point)).c_str())});
      if (p.draw)
        bindings.push_back(
            {draw_, path(("/user/hand/right/input/" + std::string(p.draw)).c_str())});
      if (p.label) {
        bindings.push_back(
            {label_, path(("/user/hand/right/input/" + std::string(p.label)).c_str())});
        bindings.push_back({label_x_, path("/user/hand/right/input/thumbstick/x")});
        bindings.push_back({label_y_, path("/user/hand/right/input/thumbstick/y")});
      }
      if (p.erase) {  // the Vive's left menu is mute: its right one erases
        const std::string hand = p.label ? "left" : "right";
        bindings.push_back(
            {erase_, path(("/user/hand/" + hand + "/input/" + std::string(p.erase)).c_str())});
      }
      auto suggested = xr_struct<XrInteractionProfileSuggestedBinding>(
          XR_TYPE_INTERACTION_PROFILE_SUGGESTED_BINDING);
      suggested.interactionProfile = path(p.profile);
      suggested.countSuggestedBindings = static_cast<uint32_t>(bindings.size());
      suggested.suggestedBindings = bindings.data();
      xr_check(xrSuggestInteractionProfileBindings(instance, &suggested),
               "xrSuggestInteractionProfileBindings");
    }
    auto attach = xr_struct<XrSessionActionSetsAttachInfo>(XR_TYPE_SESSION_ACTION_SETS_ATTACH_INFO);
    attach.countActionSets = 1;
    attach.actionSets = &set_;
    xr_check(xrAttachSessionActionSets(session, &attach), "xrAttachSessionActionSets");
    for (int h = 0; h < 2; ++h) {
      auto info = xr_struct<XrActionSpaceCreateInfo>(XR_TYPE_ACTION_SPACE_CREATE_INFO);
      info.action = grip_;
      info.subactionPath = hands_[h];
      info.poseInActionSpace.orientation.w = 1;
      xr_check(xrCreateActionSpace(session, &info, &spaces_[h]), "xrCreateActionSpace");
    }
    auto aim = xr_struct<XrActionSpaceCreateInfo>(XR_TYPE_ACTION_SPACE_CREATE_INFO);
    aim.action = aim_;
    aim.subactionPath = hands_[1];
    aim.poseInActionSpace.orientation.w = 1;
    xr_check(xrCreateActionSpace(session, &aim, &aim_space_), "xrCreateActionSpace");
    enabled_ = true;
  } catch (const Error& e) {
    spdlog::warn("OpenXR: no controllers ({}); grab organs from the desktop panel or a browser",
                 e.what());
  }
}

XrControllers::~XrControllers() {
  for (XrSpace s : spaces_)
    if (s != XR_NULL_HANDLE) xrDestroySpace(s);
  if (aim_space_ != XR_NULL_HANDLE) xrDestroySpace(aim_space_);
  if (set_ != XR_NULL_HANDLE) xrDestroyActionSet(set_);  // its actions with it
}

bool XrControllers::locate(XrSpace action_space, XrSpace space, XrTime time, Pose& pose) {
  auto location = xr_struct<XrSpaceLocation>(XR_TYPE_SPACE_LOCATION);
  if (XR_FAILED(xrLocateSpace(action_space, space, time, &location))) return false;
  const XrSpaceLocationFlags valid =
      XR_SPACE_LOCATION_POSITION_VALID_BIT | XR_SPACE_LOCATION_ORIENTATION_VALID_BIT;
  if ((location.locationFlags & valid) != valid) return false;
  const XrPosef& p = location.pose;
  pose.position = {p.position.x, p.position.y, p.position.z};
  pose.orientation =
      Eigen::Quaternionf(p.orientation.w, p.orientation.x, p.orientation.y, p.orientation.z)
          .normalized();
  return true;
}

std::array<ControllerState, 2> XrControllers::sync(XrSpace space, XrTime time) {
  std::array<ControllerState, 2> out;
  if (!enabled_) return out;
  XrActiveActionSet active{set_, XR_NULL_PATH};
  auto sync = xr_struct<XrActionsSyncInfo>(XR_TYPE_ACTIONS_SYNC_INFO);
  sync.countActiveActionSets = 1;
  sync.activeActionSets = &active;
  const XrResult r = xrSyncActions(session_, &sync);
  if (XR_FAILED(r) || r == XR_SESSION_NOT_FOCUSED) return out;  // no input while not focused
  const auto held = [&](XrAction action, XrPath hand) {
    auto get = xr_struct<XrActionStateGetInfo>(XR_TYPE_ACTION_STATE_GET_INFO);
    get.action = action;
    get.subactionPath = hand;
    auto state = xr_struct<XrActionStateBoolean>(XR_TYPE_ACTION_STATE_BOOLEAN);
    return XR_SUCCEEDED(xrGetActionStateBoolean(session_, &get, &state)) && state.isActive &&
           state.currentState;
  };
  out[0].talk = held(talk_, hands_[0]);
  out[0].mute = held(mute_, hands_[0]);
  const auto value = [&](XrAction action, XrPath hand) {
    auto get = xr_struct<XrActionStateGetInfo>(XR_TYPE_ACTION_STATE_GET_INFO);
    get.action = action;
    get.subactionPath = hand;
    auto state = xr_struct<XrActionStateFloat>(XR_TYPE_ACTION_STATE_FLOAT);
    return XR_SUCCEEDED(xrGetActionStateFloat(session_, &get, &state)) && state.isActive
               ? state.currentState
               : 0.0f;
  };
  out[1].point = held(point_, hands_[1]);
  out[1].draw = held(draw_, hands_[1]);
  out[1].label = held(label_, hands_[1]);
  out[1].label_stick = {value(label_x_, hands_[1]), value(label_y_, hands_[1])};
  out[0].erase = held(erase_, hands_[0]) || held(erase_, hands_[1]);
  out[0].volume = value(volume_, hands_[0]);
  out[1].aim_tracked = locate(aim_space_, space, time, out[1].aim);
  for (int h = 0; h < 2; ++h) {
    if (!locate(spaces_[h], space, time, out[h].pose)) continue;
    out[h].tracked = true;
    out[h].squeeze = value(squeeze_, hands_[h]);
  }
  return out;
}

}  // namespace volcast
