#pragma once
// The desktop viewer's session section (internal to volcast_viewer_desktop): the lobby (sessions
// with their participant counts, join, create, leave), who is in the session, teleport by click,
// and the round trip. Draws between ImGui::NewFrame and ImGui::Render; acts on the Participant.
#include <string>

#include "volcast/session/participant.hpp"

namespace volcast {

struct SessionPanelState {
  char new_session[65] = "OR";
  bool teleport_mode = false;  ///< the next left click on the floor teleports there
  std::string status;
};

/// Draws the section for `participant`'s snapshot `s`.
void draw_session_panel(SessionPanelState& state, Participant& participant,
                        const SessionSnapshot& s);

}  // namespace volcast
