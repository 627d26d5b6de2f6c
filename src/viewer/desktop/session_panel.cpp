#include "session_panel.hpp"

#include <imgui.h>

#include <chrono>

#include "volcast/core/text.hpp"

namespace volcast {

void draw_session_panel(SessionPanelState& state, Participant& participant,
                        const SessionSnapshot& s) {
  if (!ImGui::CollapsingHeader("session", ImGuiTreeNodeFlags_DefaultOpen)) return;
  if (s.joined) {
    ImGui::Text("in '%s' as participant %u", printable(s.session_name, 64).c_str(), s.id);
    if (ImGui::Button("leave")) participant.leave();
    ImGui::SameLine();
    ImGui::Checkbox("teleport (T, then click the floor)", &state.teleport_mode);
    if (ImGui::BeginTable("people", 3, ImGuiTableFlags_Borders)) {
      for (const char* h : {"name", "role", "avatar"}) ImGui::TableSetupColumn(h);
      ImGui::TableHeadersRow();
      for (const RemoteParticipant& p : s.others) {
        ImGui::TableNextRow();
        ImGui::TableNextColumn();
        ImGui::TextUnformatted(printable(p.name, 64).c_str());
        ImGui::TableNextColumn();
        ImGui::TextUnformatted(session::to_string(p.role));
        ImGui::TableNextColumn();
        ImGui::TextUnformatted(p.role == session::Role::kOrSite ? "site cameras"
                               : p.avatar_camera                ? "camera"
                                                                : "mesh");
      }
      ImGui::EndTable();
    }
    const ParticipantStats st = participant.stats();
    ImGui::Text("round trip p50 %.2f ms, p99 %.2f ms (%zu samples)", st.round_trip_ms_p50,
                st.round_trip_ms_p99, st.round_trip_samples);
  } else {
    ImGui::TextUnformatted("lobby");
    if (ImGui::Button("refresh")) participant.list_sessions();
    for (const session::SessionSummary& l : s.lobby) {
      ImGui::PushID(static_cast<int>(l.id));
      if (ImGui::Button("join")) participant.join(l.name, false);
      ImGui::SameLine();
      ImGui::Text("%s (%u)", printable(l.name, 64).c_str(), l.participants);
      ImGui::PopID();
    }
    ImGui::InputText("name", state.new_session, sizeof state.new_session);
    ImGui::SameLine();
    if (ImGui::Button("create")) participant.join(state.new_session, true);
  }
  if (!s.last_error.empty()) ImGui::TextWrapped("server: %s", printable(s.last_error, 300).c_str());
}

}  // namespace volcast
