#include "case_panel.hpp"

#include <imgui.h>

#include <cmath>

#include "volcast/core/text.hpp"

namespace volcast {

namespace {

std::string owner_name(const SessionSnapshot& s, uint32_t owner) {
  if (owner == 0) return "-";
  if (owner == s.id) return "you";
  for (const RemoteParticipant& p : s.others)
    if (p.id == owner) return printable(p.name, 64);
  return "participant " + std::to_string(owner);
}

Pose adjusted(const CasePanelState& st) {
  Pose p = st.held_from;
  constexpr float kDeg = static_cast<float>(M_PI / 180);
  p.orientation =
      (Eigen::AngleAxisf(st.turn_deg * kDeg, Eigen::Vector3f::UnitY()) *
       Eigen::AngleAxisf(st.tilt_deg * kDeg, Eigen::Vector3f::UnitX()) * st.held_from.orientation)
          .normalized();
  p.position.y() += st.lift_m;
  return p;
}

}  // namespace

void draw_case_panel(CasePanelState& st, Participant& participant, const SessionSnapshot& s) {
  const auto c = participant.shared_case();
  if (!c || s.case_generation != c->generation) return;
  if (!ImGui::CollapsingHeader("case", ImGuiTreeNodeFlags_DefaultOpen)) return;
  ImGui::Text("'%s'", printable(c->name, 64).c_str());
  for (size_t i = 0; i < c->objects.size() && i < s.objects.size(); ++i) {
    const ObjectView& o = s.objects[i];
    ImGui::PushID(static_cast<int>(i));
    const bool mine = o.owner != 0 && o.owner == s.id;
    if (mine) {
      if (st.held != static_cast<int>(i)) {  // just granted
        st.held = static_cast<int>(i);
        st.held_from = o.pose;
        st.turn_deg = st.tilt_deg = st.lift_m = 0;
      }
      if (ImGui::Button("release")) {
        participant.release(o.object, adjusted(st));
        st.held = -1;
      }
    } else {
      if (st.held == static_cast<int>(i)) st.held = -1;  // taken away (a swap, a reload)
      ImGui::BeginDisabled(o.owner != 0);
      if (ImGui::Button("grab")) participant.grab(o.object);
      ImGui::EndDisabled();
    }
    ImGui::SameLine();
    ImGui::Text("%s (held by %s)", printable(c->objects[i].name, 64).c_str(),
                owner_name(s, o.owner).c_str());
    if (mine) {
      bool moved = ImGui::DragFloat("turn (deg)", &st.turn_deg, 1.0f, -360, 360);
      moved |= ImGui::DragFloat("tilt (deg)", &st.tilt_deg, 1.0f, -180, 180);
      moved |= ImGui::DragFloat("lift (m)", &st.lift_m, 0.005f, -0.3f, 0.8f);
      if (moved) participant.move_object(o.object, adjusted(st));
    }
    ImGui::PopID();
  }
  if (!c->monitor || !s.monitor) return;
  ImGui::Separator();
  MonitorState m = *s.monitor;
  bool changed = false;
  int slice = m.slice;
  ImGui::Text("monitor: CT %dx%d, %d slices (set by %s)", c->monitor->width, c->monitor->height,
              c->monitor->slices, m.by ? owner_name(s, m.by).c_str() : "the server");
  if (ImGui::SliderInt("slice", &slice, 0, c->monitor->slices - 1)) {
    m.slice = static_cast<uint16_t>(slice);
    changed = true;
  }
  for (const WindowPreset& p : window_presets()) {
    if (ImGui::Button(p.name)) m.center = p.center, m.width = p.width, changed = true;
    ImGui::SameLine();
  }
  ImGui::NewLine();
  changed |= ImGui::DragFloat("window center (HU)", &m.center, 2.0f, -1500, 3000);
  changed |= ImGui::DragFloat("window width (HU)", &m.width, 2.0f, 1, 5000);
  if (!c->monitor->overlay.empty())
    changed |= ImGui::Checkbox(("overlay: " + printable(c->monitor->overlay_label, 64)).c_str(),
                               &m.overlay);
  if (changed) participant.set_monitor(m);
}

}  // namespace volcast
