#include "volcast/voice/voice_controls.hpp"

#include <algorithm>
#include <cmath>

namespace volcast::voice {

void apply_voice_input(VoiceLink& link, VoiceInput& input) {
  link.set_talking(input.talk_held);
  if (input.muted)
    link.set_muted(*input.muted);
  else if (input.toggle_mute)
    link.set_muted(!link.muted());
  for (const auto& [participant, gain] : input.volumes) link.set_volume(participant, gain);
  input.toggle_mute = false;
  input.muted.reset();
  input.volumes.clear();
}

void press_voice_buttons(VoiceInput& input, VoiceButtons& before, const VoiceButtons& now) {
  input.talk_held = now.talk;
  if (now.mute && !before.mute) input.toggle_mute = !input.toggle_mute;
  before = now;
}

Eigen::Vector3f voice_position(const SessionSnapshot& s, uint32_t id,
                               const Eigen::Vector3f& site_position) {
  if (id == 1) return site_position;
  for (const RemoteParticipant& p : s.others)
    if (p.id == id)
      return p.has_pose ? p.pose.head.position : Eigen::Vector3f(p.spot.x, 1.6f, p.spot.z);
  return site_position;
}

uint32_t step_volume(VolumeGesture& gesture, VoiceInput& input, const SessionSnapshot& s,
                     const std::vector<VoiceRow>& rows, float stick,
                     const Eigen::Vector3f& site_position, int64_t now_us) {
  if (std::abs(stick) < kVolumeRest) gesture.pushed = false;
  if (gesture.pushed || std::abs(stick) < kVolumePush || !s.has_own_body) return 0;
  gesture.pushed = true;
  const Pose& head = s.own_body.head;
  const Eigen::Vector3f forward = head.orientation * Eigen::Vector3f(0, 0, -1);
  const float min_cos = std::cos(kVolumeGazeDeg * float(M_PI) / 180);
  const VoiceRow* looked_at = nullptr;
  float best = min_cos;
  for (const RemoteParticipant& p : s.others) {
    const Eigen::Vector3f to = voice_position(s, p.id, site_position) - head.position;
    if (to.norm() < 1e-3f) continue;
    const float c = forward.dot(to.normalized());
    if (c < best) continue;
    const auto row =
        std::find_if(rows.begin(), rows.end(), [&](const VoiceRow& r) { return r.id == p.id; });
    if (row == rows.end()) continue;
    best = c;
    looked_at = &*row;
  }
  if (!looked_at) return 0;
  // The gain stepped last, for a voice not heard yet (the rows show its configured one).
  const float now_gain = gesture.shown_id == looked_at->id ? gesture.shown_gain : looked_at->volume;
  const float gain = std::clamp(now_gain + (stick > 0 ? kVolumeStep : -kVolumeStep), 0.0f, 4.0f);
  input.volumes.emplace_back(looked_at->id, gain);
  gesture.shown_id = looked_at->id;
  gesture.shown_gain = gain;
  gesture.shown_at = voice_position(s, looked_at->id, site_position);
  gesture.shown_until_us = now_us + kVolumeShownUs;
  return looked_at->id;
}

std::vector<VoiceRow> voice_rows(const SessionSnapshot& s, const VoiceStats* stats,
                                 const std::map<std::string, float>& volumes, int64_t now_us) {
  std::vector<VoiceRow> rows;
  rows.reserve(s.others.size());
  for (const RemoteParticipant& p : s.others) {
    VoiceRow row;
    row.id = p.id;
    row.name = p.name;
    row.muted = p.muted;
    if (stats) {
      const auto heard = std::find_if(stats->heard.begin(), stats->heard.end(),
                                      [&](const HeardVoice& h) { return h.id == p.id; });
      if (heard != stats->heard.end()) {
        row.speaking = heard->speaking;
        row.volume = heard->volume;
      } else if (const auto v = volumes.find(p.name); v != volumes.end()) {
        row.volume = v->second;
      }
    } else {
      row.speaking = p.last_voice_us != 0 && now_us - p.last_voice_us < kSpeakingHoldUs;
    }
    rows.push_back(std::move(row));
  }
  return rows;
}

}  // namespace volcast::voice
