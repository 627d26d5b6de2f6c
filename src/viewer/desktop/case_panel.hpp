#pragma once
// The desktop viewer's case section (internal to volcast_viewer_desktop): the case's objects with
// who holds each, grab / release, and while holding, turn, tilt and lift by dragging with the
// mouse (every change goes to the others at once); the monitor's slice, window presets, free
// window/level and the overlay, shared with everyone. Draws between ImGui::NewFrame and
// ImGui::Render; acts on the Participant.
#include "volcast/session/participant.hpp"

namespace volcast {

struct CasePanelState {
  int held = -1;   ///< the object this viewer asked to hold (-1: none)
  Pose held_from;  ///< its pose when it was granted
  float turn_deg = 0, tilt_deg = 0, lift_m = 0;
};

/// Draws the section (nothing before a case has arrived).
void draw_case_panel(CasePanelState& state, Participant& participant, const SessionSnapshot& s);

}  // namespace volcast
