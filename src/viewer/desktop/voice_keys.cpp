#include "volcast/viewer/voice_keys.hpp"

namespace volcast {
namespace {

constexpr int kRelease = 0, kPress = 1;                 // GLFW_RELEASE, GLFW_PRESS
constexpr int kCommandMods = 0x0002 | 0x0004 | 0x0008;  // GLFW_MOD_CONTROL, _ALT, _SUPER

}  // namespace

bool voice_key(voice::VoiceInput& input, int key, int action, int mods) {
  if (key == kTalkKey && (action == kPress || action == kRelease)) {
    const bool held = action == kPress;
    if (input.talk_held == held) return false;
    input.talk_held = held;
    return true;
  }
  if (key == kMuteKey && action == kPress && !(mods & kCommandMods)) {
    input.toggle_mute = !input.toggle_mute;
    return true;
  }
  return false;
}

}  // namespace volcast
