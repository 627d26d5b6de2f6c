#include "panel.hpp"

#include <imgui.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

namespace volcast {
namespace {

constexpr float kToRadians = std::numbers::pi_v<float> / 180;
// Values typed in (Ctrl+click) stay within the slider's range, which the renderer accepts.
constexpr ImGuiSliderFlags kClamp = ImGuiSliderFlags_AlwaysClamp;

void help(const char* text) {
  if (ImGui::IsItemHovered()) ImGui::SetTooltip("%s", text);
}

void renderer_section(CameraPassOptions& pass, const std::string& blend_off) {
  int surface = pass.surface == Surface::kMesh ? 1 : 0;
  if (ImGui::Combo("surface", &surface, "splats\0mesh\0"))
    pass.surface = surface == 1 ? Surface::kMesh : Surface::kSplats;
  if (pass.surface == Surface::kSplats) {
    int size = static_cast<int>(pass.splat_size);
    if (ImGui::Combo("splat size", &size, "fixed pixels\0footprint\0adaptive\0"))
      pass.splat_size = static_cast<SplatSize>(size);
    if (pass.splat_size == SplatSize::kFixedPixels)
      ImGui::SliderFloat("point size (px)", &pass.fixed_point_px, 1, 64, "%.1f", kClamp);
    else
      ImGui::SliderFloat("splat scale", &pass.splat_scale, 0.1f, 10, "%.2f",
                         ImGuiSliderFlags_Logarithmic | kClamp);
  } else {
    ImGui::SliderFloat("edge ratio", &pass.max_edge_ratio, 0.001f, 1, "%.3f",
                       ImGuiSliderFlags_Logarithmic | kClamp);
    help("a triangle is dropped when an edge is longer than this x the depth of its nearer corner");
  }
  ImGui::Checkbox("blend overlapping cameras", &pass.blend);
  if (!blend_off.empty() && !pass.blend)
    ImGui::TextWrapped("%s; ticking the box blends again", blend_off.c_str());
  if (pass.blend) {
    bool reliable = pass.blend_weights == BlendWeights::kReliability;
    ImGui::Checkbox("weigh by reliability", &reliable);
    help(
        "angle, distance and distance to a depth edge, edges eroded, soft depth tolerance; "
        "off: the first weights (angle and distance)");
    pass.blend_weights = reliable ? BlendWeights::kReliability : BlendWeights::kAngleDistance;
  }
  ImGui::Checkbox("balance colour between cameras", &pass.balance_colour);
}

void camera_section(ViewerControls& c, const PanelInfo& info, size_t i) {
  const auto& stats = info.live.cameras;
  const std::string name =
      i < stats.size() && !stats[i].description.empty() ? stats[i].description : "camera";
  ImGui::PushID(static_cast<int>(i));
  const bool only = c.sliders.size() == 1;  // a lone camera's controls start open
  if (ImGui::TreeNodeEx("camera", only ? ImGuiTreeNodeFlags_DefaultOpen : 0, "%zu: %s", i,
                        name.c_str())) {
    CameraLook& look = c.pass.cameras[i];
    ImGui::Checkbox("visible", &look.visible);
    ImGui::ColorEdit4("tint", look.tint.data(), ImGuiColorEditFlags_NoInputs);
    help("RGB and strength (alpha)");
    PoseSliders& s = c.sliders[i];
    c.poses_changed |=
        ImGui::SliderFloat3("move (mm)", s.translation_mm.data(), -2000, 2000, "%.0f", kClamp);
    help("along the world's x, y, z axes");
    c.poses_changed |=
        ImGui::SliderFloat3("turn (deg)", s.rotation_deg.data(), -180, 180, "%.1f", kClamp);
    help("about the world's x, then y, then z axis, through the camera (Rz * Ry * Rx)");
    if (ImGui::Button("reset")) {
      s = PoseSliders{};
      c.poses_changed = true;
    }
    ImGui::TreePop();
  }
  ImGui::PopID();
}

void filter_section(ViewerControls& c, const PanelInfo& info) {
  c.filter_changed |= ImGui::Checkbox("keep a sphere", &c.keep_on);
  c.filter_changed |= ImGui::DragFloat3("centre (m)", c.keep.center.data(), 0.01f);
  c.filter_changed |= ImGui::SliderFloat("radius (m)", &c.keep.radius_m, 0.05f, 5, "%.2f", kClamp);
  if (ImGui::Button("centre at pivot")) {
    c.keep.center = info.pivot;
    c.filter_changed = true;
  }
  c.filter_changed |= ImGui::Checkbox("hide a headset box", &c.hide_on);
  c.filter_changed |= ImGui::DragFloat3("headset (m)", c.hide_position_m.data(), 0.01f);
  c.filter_changed |= ImGui::SliderFloat("yaw (deg)", &c.hide_yaw_deg, -180, 180, "%.0f", kClamp);
  if (ImGui::Button("headset at eye")) {
    c.hide_position_m = info.eye;
    c.filter_changed = true;
  }
}

void live_section(const PanelInfo& info) {
  const LiveStats& live = info.live;
  if (!live.connection.empty())
    ImGui::TextColored(ImVec4(1, 0.4f, 0.3f, 1), "%s", live.connection.c_str());
  if (live.reconnects > 0)
    ImGui::Text("reconnected %llu time(s)", static_cast<unsigned long long>(live.reconnects));
  ImGui::Text("tier: %s%s%s", to_string(live.tier).c_str(),
              live.lossless_depth ? "" : "  (LOSSY DEPTH)",
              live.adaptive ? "  adaptive" : "  pinned");
  if (live.path_mbit_s > 0) ImGui::Text("path: about %.1f Mbit/s", live.path_mbit_s);
  for (const TierEvent& e : live.tier_events)
    ImGui::TextWrapped("%s %s: %s", e.notice ? "kept" : "->", to_string(e.tier).c_str(),
                       e.reason.c_str());
  ImGui::Text("frame sets received: %llu",
              static_cast<unsigned long long>(live.frame_sets_received));
  if (ImGui::BeginTable("cameras", 5, ImGuiTableFlags_Borders)) {
    for (const char* h : {"camera", "fps", "p50 ms", "Mbit/s", "dropped"})
      ImGui::TableSetupColumn(h);
    ImGui::TableHeadersRow();
    for (size_t i = 0; i < live.cameras.size(); ++i) {
      const CameraStats& s = live.cameras[i];
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      ImGui::Text("%zu", i);
      ImGui::TableNextColumn();
      ImGui::Text("%.1f", s.received_fps);
      ImGui::TableNextColumn();
      ImGui::Text("%.1f", s.latency_ms_p50);
      ImGui::TableNextColumn();
      ImGui::Text("%.1f", s.mbit_per_s);
      ImGui::TableNextColumn();
      ImGui::Text("%llu", static_cast<unsigned long long>(s.frames_dropped));
    }
    ImGui::EndTable();
  }
  if (!live.stages.empty() && ImGui::BeginTable("stages", 3, ImGuiTableFlags_Borders)) {
    for (const char* h : {"stage", "p50 ms", "p99 ms"}) ImGui::TableSetupColumn(h);
    ImGui::TableHeadersRow();
    for (const StageLatency& s : live.stages) {
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(s.stage.data(), s.stage.data() + s.stage.size());
      ImGui::TableNextColumn();
      ImGui::Text("%.1f", s.p50_ms);
      ImGui::TableNextColumn();
      ImGui::Text("%.1f", s.p99_ms);
    }
    ImGui::EndTable();
  }
}

}  // namespace

ViewerControls initial_controls(const CameraPassOptions& pass, const AvatarFilter& filter,
                                size_t cameras) {
  ViewerControls c;
  c.pass = pass;
  c.pass.cameras.resize(cameras);
  c.sliders.resize(cameras);
  if (filter.keep) {
    c.keep_on = true;
    c.keep = *filter.keep;
  }
  if (filter.hide) {
    const RigidTransform& pose = filter.hide->world_from_headset;
    c.hide_on = true;
    c.hide_position_m = pose.translation.cast<float>();
    // The yaw about +y that --hide-headset gives (other turns are not shown by the panel).
    c.hide_yaw_deg =
        static_cast<float>(std::atan2(pose.rotation(0, 2), pose.rotation(2, 2))) / kToRadians;
  }
  return c;
}

AvatarFilter avatar_filter_of(const ViewerControls& c) {
  AvatarFilter filter;
  if (c.keep_on) filter.keep = c.keep;
  if (c.hide_on) {
    HideBox box;
    box.world_from_headset.translation = c.hide_position_m.cast<double>();
    box.world_from_headset.rotation =
        Eigen::AngleAxisd(c.hide_yaw_deg * kToRadians, Eigen::Vector3d::UnitY()).toRotationMatrix();
    filter.hide = box;
  }
  return filter;
}

void draw_panel(ViewerControls& c, const PanelInfo& info, const std::function<void()>& first) {
  ImGui::SetNextWindowPos(ImVec2(10, 10), ImGuiCond_FirstUseEver);
  // As tall as its open sections, within the window (then it scrolls).
  ImGui::SetNextWindowSizeConstraints(
      ImVec2(380, 0), ImVec2(380, std::max(100.0f, ImGui::GetIO().DisplaySize.y - 20)));
  if (!ImGui::Begin("volcast (H hides)", nullptr, ImGuiWindowFlags_AlwaysAutoResize)) {
    ImGui::End();
    return;
  }
  ImGui::TextWrapped("%s", info.gl_renderer.c_str());
  ImGui::PushStyleColor(ImGuiCol_Text, ImGui::GetStyle().Colors[ImGuiCol_TextDisabled]);
  ImGui::TextWrapped(
      "left drag orbit, wheel zoom, right drag look, WASD/QE fly (Shift: faster), R reset, "
      "F12/P screenshot, Ctrl+S save poses, H hide this panel");
  ImGui::PopStyleColor();
  if (ImGui::Button("reset view")) c.reset_view = true;
  ImGui::SameLine();
  if (ImGui::Button("screenshot (F12)")) c.screenshot = true;
  if (first) first();
  if (ImGui::CollapsingHeader("renderer", ImGuiTreeNodeFlags_DefaultOpen))
    renderer_section(c.pass, c.blend_off);
  if (ImGui::CollapsingHeader("cameras", ImGuiTreeNodeFlags_DefaultOpen)) {
    for (size_t i = 0; i < c.sliders.size(); ++i) camera_section(c, info, i);
    if (ImGui::Button("save poses (Ctrl+S)")) c.save = true;
    ImGui::SameLine();
    ImGui::TextWrapped("to %s", info.site_config.string().c_str());
  }
  if (ImGui::CollapsingHeader("avatar filters")) filter_section(c, info);
  if (ImGui::CollapsingHeader("live", ImGuiTreeNodeFlags_DefaultOpen)) live_section(info);
  if (!c.status.empty()) ImGui::TextWrapped("%s", c.status.c_str());
  ImGui::End();
}

}  // namespace volcast
