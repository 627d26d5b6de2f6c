#pragma once
// The desktop window's voice keys (issue 35) as a pure function of GLFW key events: hold V to
// talk (with push-to-talk, `volcast view --push-to-talk`), press M to mute or unmute the
// microphone. Neither key is taken by navigation (navigation.hpp, desktop.hpp).
#include "volcast/voice/voice_controls.hpp"

namespace volcast {

inline constexpr int kTalkKey = 86;  ///< GLFW_KEY_V: held to talk
inline constexpr int kMuteKey = 77;  ///< GLFW_KEY_M: each press toggles mute

/// One key event into `input`: `key` a GLFW key code, `action` GLFW_RELEASE (0), GLFW_PRESS (1) or
/// GLFW_REPEAT (2), `mods` GLFW_MOD_* bits. M pressed without Ctrl, Alt or Super toggles mute
/// (VoiceInput::toggle_mute; a second press before it is applied undoes the first). V pressed
/// (with any modifier: Shift+V still talks) holds talk_held, V released lets go. Returns whether
/// the event changed `input`.
bool voice_key(voice::VoiceInput& input, int key, int action, int mods);

}  // namespace volcast
