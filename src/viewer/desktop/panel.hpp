#pragma once
// The desktop viewer's Dear ImGui panel (internal to volcast_viewer_desktop): it edits a plain
// ViewerControls, and the window loop (window.cpp) acts on what changed.
#include <Eigen/Core>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "volcast/pipeline/frame_feed.hpp"
#include "volcast/reconstruct/avatar_filter.hpp"
#include "volcast/render/camera_renderer.hpp"
#include "volcast/viewer/pose_sliders.hpp"

namespace volcast {

/// What the panel edits. The request flags are set by the panel (or a key) and cleared by the
/// window loop once it has acted on them.
struct ViewerControls {
  CameraPassOptions pass;            ///< cameras: one CameraLook per camera
  std::vector<PoseSliders> sliders;  ///< per camera
  bool keep_on = false;              ///< avatar filter: keep a sphere
  KeepSphere keep;
  bool hide_on = false;  ///< avatar filter: hide a headset box at hide_position_m turned by yaw
  Eigen::Vector3f hide_position_m = Eigen::Vector3f::Zero();
  float hide_yaw_deg = 0;
  bool show_panel = true;
  // Requests.
  bool poses_changed = false, filter_changed = false;
  bool save = false, screenshot = false, reset_view = false;
  std::string status;     ///< the outcome of the last Save or screenshot, shown in the panel
  std::string blend_off;  ///< why the frame budget turned blending off, shown under its box
};

/// Controls starting from the options' pass and avatar filter, for `cameras` cameras.
ViewerControls initial_controls(const CameraPassOptions& pass, const AvatarFilter& filter,
                                size_t cameras);
/// The avatar filter the controls describe.
AvatarFilter avatar_filter_of(const ViewerControls& controls);

/// What the panel shows but does not edit.
struct PanelInfo {
  const LiveStats& live;
  const std::string& gl_renderer;
  Eigen::Vector3f pivot, eye;  ///< the view's target and eye, world frame, metres
  const std::filesystem::path& site_config;
};

/// Draws the panel (between ImGui::NewFrame and ImGui::Render), editing `controls`. `first`, if
/// set, draws sections that go above the renderer's and the cameras' (a session's: its mute box
/// stays in view in a 720p window).
void draw_panel(ViewerControls& controls, const PanelInfo& info,
                const std::function<void()>& first = {});

}  // namespace volcast
