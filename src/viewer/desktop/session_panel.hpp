#pragma once
// The desktop viewer's session section (internal to volcast_viewer_desktop): the lobby (sessions
// with their participant counts, join, create, leave), who is in the session with their voice
// (speaking, muted, a volume slider each), your microphone's mute and push-to-talk, teleport by
// click, and the round trip. Draws between ImGui::NewFrame and ImGui::Render; acts on the
// Participant, and leaves what the voice controls ask in SessionPanelState::voice.
#include <imgui.h>

#include <chrono>
#include <map>
#include <string>

#include "volcast/session/participant.hpp"
#include "volcast/voice/voice_controls.hpp"

namespace volcast {

struct SessionPanelState {
  char new_session[65] = "OR";
  bool teleport_mode = false;  ///< the next left click on the floor teleports there
  std::string status;
  /// The voice keys (voice_keys.hpp) and the panel's mute box and sliders, applied to the link
  /// once per frame by the window (apply_voice_input).
  voice::VoiceInput voice;
  voice::VoiceStats voice_stats;  ///< the link's stats(), refreshed every kVoiceStatsPeriod
  std::chrono::steady_clock::time_point voice_stats_at;
  std::map<uint32_t, float> volumes;  ///< gains set by the sliders (shown over voice_stats')
};

/// How often the panel reads the voice link's stats (its speaking flags).
inline constexpr std::chrono::milliseconds kVoiceStatsPeriod{100};

/// Draws the section for `participant`'s snapshot `s`; `voice` is its voice link, or null (none,
/// or not yet made): then the list shows who is muted and who sends voice, without controls.
void draw_session_panel(SessionPanelState& state, Participant& participant,
                        const SessionSnapshot& s, const voice::VoiceLink* voice);

/// Whether the room is being recorded (SessionSnapshot::recording, 0x53), over the picture at
/// the top right of a `display_width` pixels wide window, panel shown or not: a red dot, "REC",
/// who records and since when (local time). Nothing while no recording runs. `text`: the font's
/// size in pixels. Draws into `list` between ImGui::NewFrame and ImGui::Render.
void draw_recording_badge(ImDrawList* list, const session::RecordingState& r, float text,
                          float display_width);

}  // namespace volcast
