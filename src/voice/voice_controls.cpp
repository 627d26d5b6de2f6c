#include "volcast/voice/voice_controls.hpp"

#include <algorithm>

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
