#pragma once
// Private to src/demo: the demo session's spoken exchange (issue 35). The OR site and the two
// remote participants each say a line, one after another, from microphone files made with
// Debian's espeak-ng (synthetic voices); each hears the others on a loudspeaker file (the remote
// participants in stereo with HRTF, the OR's loudspeaker a mono mix), written to out/voice/ with
// what it measured (mouth-to-ear latency, concealment) as JSON.
#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include "volcast/session/hub.hpp"
#include "volcast/voice/site_voice.hpp"
#include "volcast/voice/voice_link.hpp"

namespace volcast::demo {

/// One speaker's line: who (a file name stem), the words, the espeak-ng voice, when it starts
/// (seconds after the exchange begins).
struct Line {
  std::string who, words, espeak_voice;
  double at_s = 0;
};

/// The exchange's lines: the OR site, then "session_camera_avatar", then "session_mesh_avatar".
const std::vector<Line>& demo_lines();

struct Exchange {
  std::filesystem::path dir;                          ///< out/voice
  int64_t start_us = 0;                               ///< wall clock when the exchange begins
  std::map<std::string, std::filesystem::path> mics;  ///< by `who`
};

/// Makes out/voice/said_<who>.wav (espeak-ng) and the microphone files mic_<who>.wav (each line
/// at its time), the exchange beginning `lead_s` from now. Nothing (with a warning) when
/// espeak-ng is not installed.
std::optional<Exchange> prepare_exchange(const std::filesystem::path& out, double lead_s);

/// The voice settings of remote participant `who` in `e`.
voice::VoiceConfig participant_voice(const Exchange& e, const std::string& who);

/// The OR site's voice: its microphone file and a loudspeaker file, wired to `hub` (the caller
/// sets SessionHubConfig::site_listener to put() on it).
std::unique_ptr<voice::SiteVoice> site_voice(const Exchange& e, SessionHub& hub);

/// Writes heard_or_site.json and prints what the OR site heard, each speaker by its name in
/// `names` (participant id -> display name; "participant N" where it has none).
void report_site(const Exchange& e, const voice::SiteVoiceStats& s,
                 const std::map<uint32_t, std::string>& names);

}  // namespace volcast::demo
