#pragma once
// A viewer's voice controls (issue 35): what the desktop window's keys and panel and the headset's
// controller buttons ask of the participant's VoiceLink, and the list of the others the panel
// shows (speaking, muted, volume). Plain structs and free functions: a viewer fills a VoiceInput
// from its keys or buttons and its panel, then calls apply_voice_input once per frame.
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "volcast/session/participant.hpp"
#include "volcast/voice/voice_link.hpp"

namespace volcast::voice {

/// What the user asked of the voice link. talk_held is a state (held now); the others are requests
/// made since the last apply_voice_input, which clears them.
struct VoiceInput {
  bool talk_held = false;     ///< the push-to-talk key (V) or button is held down now
  bool toggle_mute = false;   ///< the mute key (M) or button was pressed
  std::optional<bool> muted;  ///< the panel's mute checkbox was set to this
  /// Volume sliders moved: participant id, gain (0 silent, 1 as sent, up to 4).
  std::vector<std::pair<uint32_t, float>> volumes;
};

/// Acts on `link`: set_talking(talk_held); set_muted with the checkbox's value if it was set, else
/// toggled if toggle_mute; set_volume for each slider, in order. Then clears the requests
/// (toggle_mute, muted, volumes); talk_held stays.
void apply_voice_input(VoiceLink& link, VoiceInput& input);

/// A controller's voice buttons in one frame (held or not).
struct VoiceButtons {
  bool talk = false;  ///< push-to-talk: held to talk
  bool mute = false;  ///< each press toggles mute
};

/// A headset's buttons into `input`, frame by frame: talk_held follows `now.talk`; mute toggles
/// when the mute button goes down (`before.mute` false, `now.mute` true). Then before = now.
void press_voice_buttons(VoiceInput& input, VoiceButtons& before, const VoiceButtons& now);

/// How long after its last voice a participant still counts as speaking, µs (as the avatars'
/// speaking ball, session_scene.cpp).
inline constexpr int64_t kSpeakingHoldUs = 300'000;

/// Another participant as the voice panel lists it.
struct VoiceRow {
  uint32_t id = 0;
  std::string name;
  bool speaking = false;  ///< its voice is heard now
  bool muted = false;     ///< it muted its microphone (VoiceState, 0x4f)
  float volume = 1;       ///< the gain its voice plays at: 0 silent, 1 as sent, up to 4
};

/// The rows for everyone in `s.others`, in that order. With `stats` (the link's, null without a
/// link): speaking is HeardVoice::speaking (voice energy in the last 300 ms as played) and volume
/// HeardVoice::volume for a participant the link heard, else false and `volumes[name]` (the
/// link's VoiceConfig::volumes) or 1. Without: speaking is a voice packet within kSpeakingHoldUs
/// before `now_us` (local wall clock), volume 1. muted is always RemoteParticipant::muted.
std::vector<VoiceRow> voice_rows(const SessionSnapshot& s, const VoiceStats* stats,
                                 const std::map<std::string, float>& volumes, int64_t now_us);

/// The headset's per-participant volume (no panel in VR): look at a participant, push the left
/// thumbstick up or down. Each push past kVolumePush steps the volume of the participant whose
/// voice comes from nearest the head's forward direction, within kVolumeGazeDeg, by kVolumeStep
/// (0 to 4, as the desktop panel's slider); the stick must come back under kVolumeRest before
/// the next step. The voice comes from a participant's head (room frame), before its first pose
/// from its spot 1.6 m high, and the OR site's (participant 1) from VoiceConfig::site_position.
struct VolumeGesture {
  bool pushed = false;    ///< the stick is out and has stepped (or was out at the start)
  uint32_t shown_id = 0;  ///< the participant stepped last (0: none yet)
  float shown_gain = 1;   ///< its volume now
  Eigen::Vector3f shown_at = Eigen::Vector3f::Zero();  ///< where its voice came from (room frame)
  int64_t shown_until_us = 0;  ///< show that volume over its head until then (local wall clock)
};
inline constexpr float kVolumePush = 0.6f;      ///< thumbstick y, out of 1
inline constexpr float kVolumeRest = 0.3f;      ///< thumbstick y, out of 1
inline constexpr float kVolumeGazeDeg = 20.0f;  ///< degrees off the head's forward (-z)
inline constexpr float kVolumeStep = 0.25f;     ///< gain per push
inline constexpr int64_t kVolumeShownUs = 2'000'000;

/// Where participant `id`'s voice comes from in `s` (room frame, metres): its head, before its
/// first pose its spot 1.6 m high; the OR site (1), or an id not in `s`, at `site_position`.
Eigen::Vector3f voice_position(const SessionSnapshot& s, uint32_t id,
                               const Eigen::Vector3f& site_position);

/// One frame of the gesture: `stick` is the left thumbstick's y (-1 down .. 1 up), `s` the
/// snapshot (its own_body.head: the listener's head, room frame), `rows` the voice rows
/// (voice_rows: the volumes now). A step appends (id, gain) to input.volumes and returns the id;
/// else 0 (no push, the stick still out, nobody looked at, or no head yet).
uint32_t step_volume(VolumeGesture& gesture, VoiceInput& input, const SessionSnapshot& s,
                     const std::vector<VoiceRow>& rows, float stick,
                     const Eigen::Vector3f& site_position, int64_t now_us);

}  // namespace volcast::voice
