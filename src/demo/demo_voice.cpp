#include "demo_voice.hpp"

#include <spdlog/spdlog.h>

#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>

#include "volcast/audio/wav.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"

namespace volcast::demo {
namespace fs = std::filesystem;

const std::vector<Line>& demo_lines() {
  static const std::vector<Line> lines{
      {"or_site", "Can you both see the liver on the table?", "en-us", 0.0},
      {"session_camera_avatar", "Yes. Clamp the portal vein there, by my hand.", "en-gb", 2.8},
      {"session_mesh_avatar", "The tumour is in segment eight. Look at the monitor.", "en-us+f3",
       6.0}};
  return lines;
}

std::optional<Exchange> prepare_exchange(const fs::path& out, double lead_s) {
  if (std::system("command -v espeak-ng > /dev/null 2>&1") != 0) {
    spdlog::warn("demo: espeak-ng is not installed: the session runs without its spoken exchange");
    return std::nullopt;
  }
  Exchange e;
  e.dir = out / "voice";
  fs::create_directories(e.dir);
  for (const Line& l : demo_lines()) {
    const fs::path said = e.dir / ("said_" + l.who + ".wav");
    const std::string command =
        "espeak-ng -v '" + l.espeak_voice + "' -s 150 -w '" + said.string() + "' '" + l.words + "'";
    if (std::system(command.c_str()) != 0) throw Error("demo: espeak-ng failed: " + command);
    // The line at its time, silence around it: what the microphone picks up.
    const std::vector<float> words = audio::read_voice(said);
    audio::Pcm mic;
    mic.samples.assign(static_cast<size_t>(l.at_s * audio::kSampleRate), 0.0f);
    mic.samples.insert(mic.samples.end(), words.begin(), words.end());
    mic.samples.resize(mic.samples.size() + audio::kSampleRate / 2, 0.0f);
    e.mics[l.who] = e.dir / ("mic_" + l.who + ".wav");
    audio::write_wav(e.mics[l.who], mic);
  }
  e.start_us = wall_clock_us() + static_cast<int64_t>(lead_s * 1e6);
  return e;
}

voice::VoiceConfig participant_voice(const Exchange& e, const std::string& who) {
  voice::VoiceConfig v;
  v.mic = e.mics.at(who).string();
  v.mic_start_us = e.start_us;
  v.speaker = (e.dir / ("heard_" + who + ".wav")).string();
  return v;
}

std::unique_ptr<voice::SiteVoice> site_voice(const Exchange& e, SessionHub& hub) {
  voice::SiteVoiceConfig v;
  v.echo_cancellation = false;  // files: no room between the loudspeaker and the microphone
  return std::make_unique<voice::SiteVoice>(
      v, voice::open_microphone(e.mics.at("or_site").string(), e.start_us),
      voice::open_speaker((e.dir / "heard_or_site.wav").string(), 1),
      [&hub](const session::VoicePacketView& p) { hub.site_voice(p); });
}

void report_site(const Exchange& e, const voice::SiteVoiceStats& s,
                 const std::map<uint32_t, std::string>& names) {
  nlohmann::json heard = nlohmann::json::array();
  std::printf("\nthe OR site's loudspeaker (%s):\n", (e.dir / "heard_or_site.wav").c_str());
  for (const auto& h : s.heard) {
    const auto name = names.find(h.id);
    const std::string who =
        name != names.end() ? name->second : "participant " + std::to_string(h.id);
    heard.push_back({{"id", h.id},
                     {"name", who},
                     {"packets", h.stream.packets},
                     {"concealed_percent", h.stream.concealed_percent()},
                     {"latency_ms_p50", h.latency_ms_p50},
                     {"latency_ms_p99", h.latency_ms_p99}});
    std::printf(
        "  heard %s: %llu packets, mouth-to-ear p50 %.0f ms p99 %.0f ms, %.1f %% concealed\n",
        who.c_str(), static_cast<unsigned long long>(h.stream.packets), h.latency_ms_p50,
        h.latency_ms_p99, h.stream.concealed_percent());
  }
  nlohmann::json j{{"started_us", s.started_us},
                   {"packets_sent", s.packets_sent},
                   {"dtx_frames", s.dtx_frames},
                   {"heard", heard}};
  std::ofstream(e.dir / "heard_or_site.json") << j.dump(2) << "\n";
}

}  // namespace volcast::demo
