#include "session_panel.hpp"

#include <imgui.h>

#include <chrono>
#include <ctime>
#include <string>

#include "volcast/core/clock.hpp"
#include "volcast/core/text.hpp"

namespace volcast {
namespace {

// As the avatars' badges (voice_badge_primitives): green speaking, red muted.
const ImVec4 kSpeakingColor(0.25f, 0.9f, 0.35f, 1), kMutedColor(0.95f, 0.25f, 0.2f, 1),
    kQuietColor(0.45f, 0.45f, 0.45f, 1);

// A coloured dot (the height of a line of text) and a word after it.
void badge(const ImVec4& color, const char* word) {
  const float h = ImGui::GetTextLineHeight();
  const ImVec2 at = ImGui::GetCursorScreenPos();
  ImGui::GetWindowDrawList()->AddCircleFilled(ImVec2(at.x + h / 2, at.y + h / 2), h * 0.35f,
                                              ImGui::GetColorU32(color));
  ImGui::Dummy(ImVec2(h, h));
  ImGui::SameLine();
  ImGui::TextColored(color, "%s", word);
}

// Your microphone: mute (M) and, with push-to-talk, whether V is held.
void voice_controls(SessionPanelState& state, const voice::VoiceLink& voice) {
  bool muted = voice.muted();
  if (state.voice.toggle_mute) muted = !muted;  // a key press not applied yet
  if (ImGui::Checkbox("mute my microphone (M)", &muted)) state.voice.muted = muted;
  ImGui::SameLine();
  if (voice.config().mic.empty())
    ImGui::TextDisabled("no microphone (--mic)");
  else if (muted)
    badge(kMutedColor, "muted");
  else if (!voice.config().push_to_talk)
    badge(kSpeakingColor, "open");
  else if (state.voice.talk_held)
    badge(kSpeakingColor, "talking (V held)");
  else
    badge(kQuietColor, "hold V to talk");
}

// Who is here, their voice (speaking / muted) and, with a voice link, a volume slider each.
void people_table(SessionPanelState& state, const SessionSnapshot& s,
                  const voice::VoiceLink* voice) {
  const auto now = std::chrono::steady_clock::now();
  if (voice && now - state.voice_stats_at >= kVoiceStatsPeriod) {
    state.voice_stats = voice->stats();  // sorts its latencies: not every frame
    state.voice_stats_at = now;
  }
  const std::vector<voice::VoiceRow> rows = voice::voice_rows(
      s, voice ? &state.voice_stats : nullptr,
      voice ? voice->config().volumes : std::map<std::string, float>{}, wall_clock_us());
  const int columns = voice ? 5 : 4;
  if (!ImGui::BeginTable("people", columns, ImGuiTableFlags_Borders)) return;
  for (const char* h : {"name", "role", "avatar", "voice"}) ImGui::TableSetupColumn(h);
  if (voice) ImGui::TableSetupColumn("volume", ImGuiTableColumnFlags_WidthFixed, 110);
  ImGui::TableHeadersRow();
  for (size_t i = 0; i < s.others.size() && i < rows.size(); ++i) {
    const RemoteParticipant& p = s.others[i];
    const voice::VoiceRow& row = rows[i];
    ImGui::PushID(static_cast<int>(p.id));
    ImGui::TableNextRow();
    ImGui::TableNextColumn();
    ImGui::TextUnformatted(printable(p.name, 64).c_str());
    ImGui::TableNextColumn();
    ImGui::TextUnformatted(session::to_string(p.role));
    ImGui::TableNextColumn();
    ImGui::TextUnformatted(p.role == session::Role::kOrSite ? "site cameras"
                           : p.avatar_camera                ? "camera"
                                                            : "mesh");
    ImGui::TableNextColumn();
    if (row.muted)
      badge(kMutedColor, "muted");
    else if (row.speaking)
      badge(kSpeakingColor, "speaking");
    else
      badge(kQuietColor, "");
    if (voice) {
      ImGui::TableNextColumn();
      const auto set = state.volumes.find(p.id);
      float gain = set != state.volumes.end() ? set->second : row.volume;
      ImGui::SetNextItemWidth(-1);
      if (ImGui::SliderFloat("##volume", &gain, 0, 4, "%.2f", ImGuiSliderFlags_AlwaysClamp)) {
        state.volumes[p.id] = gain;
        state.voice.volumes.emplace_back(p.id, gain);
      }
      if (ImGui::IsItemHovered())
        ImGui::SetTooltip("0 silent, 1 as sent, up to 4 (Ctrl+click to type)");
    }
    ImGui::PopID();
  }
  ImGui::EndTable();
}

}  // namespace

void draw_session_panel(SessionPanelState& state, Participant& participant,
                        const SessionSnapshot& s, const voice::VoiceLink* voice) {
  if (!ImGui::CollapsingHeader("session", ImGuiTreeNodeFlags_DefaultOpen)) return;
  if (s.joined) {
    ImGui::Text("in '%s' as participant %u", printable(s.session_name, 64).c_str(), s.id);
    if (ImGui::Button("leave")) participant.leave();
    ImGui::SameLine();
    ImGui::Checkbox("teleport (T, then click the floor)", &state.teleport_mode);
    if (voice) voice_controls(state, *voice);
    people_table(state, s, voice);
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

void draw_recording_badge(ImDrawList* list, const session::RecordingState& r, float text,
                          float display_width) {
  if (!r.recording) return;
  const std::time_t since = static_cast<std::time_t>(r.since_us / 1'000'000);
  std::tm local{};
  localtime_r(&since, &local);
  char clock[16];
  std::strftime(clock, sizeof clock, "%H:%M", &local);
  const std::string line =
      "REC  recorded by " + printable(r.by, session::kMaxRecorderBytes) + ", since " + clock;
  ImFont* font = ImGui::GetFont();
  const ImVec2 extent = font->CalcTextSizeA(text, 1e9f, 0, line.c_str());
  const float pad = text * 0.4f, dot = text * 0.35f;
  const ImVec2 max(display_width - pad, pad + extent.y + 2 * pad);
  const ImVec2 min(max.x - extent.x - 3 * pad - 2 * dot, pad);
  list->AddRectFilled(min, max, IM_COL32(20, 20, 20, 220), pad);
  list->AddCircleFilled(ImVec2(min.x + pad + dot, (min.y + max.y) / 2), dot,
                        IM_COL32(230, 30, 30, 255));
  list->AddText(font, text, ImVec2(min.x + 2 * pad + 2 * dot, min.y + pad),
                IM_COL32(255, 255, 255, 255), line.c_str());
}

}  // namespace volcast
