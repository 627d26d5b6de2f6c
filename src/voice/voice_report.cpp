#include "volcast/voice/voice_report.hpp"

#include <cstdio>
#include <fstream>

#include "volcast/core/error.hpp"
#include "volcast/core/text.hpp"

namespace volcast::voice {

nlohmann::json to_json(const VoiceStats& s) {
  nlohmann::json heard = nlohmann::json::array();
  for (const HeardVoice& h : s.heard)
    heard.push_back({{"id", h.id},
                     {"name", h.name},
                     {"packets", h.stream.packets},
                     {"lost", h.stream.lost},
                     {"late", h.stream.late},
                     {"duplicates", h.stream.duplicates},
                     {"malformed", h.stream.malformed},
                     {"concealed_percent", h.stream.concealed_percent()},
                     {"jitter_delay_ms", h.stream.delay_ms},
                     {"latency_ms_p50", h.latency_ms_p50},
                     {"latency_ms_p99", h.latency_ms_p99},
                     {"speaking", h.speaking},
                     {"muted", h.muted},
                     {"volume", h.volume}});
  return {{"started_us", s.started_us},
          {"frames_captured", s.frames_captured},
          {"frames_played", s.frames_played},
          {"frames_underrun", s.frames_underrun},
          {"packets_sent", s.packets_sent},
          {"dtx_frames", s.dtx_frames},
          {"bytes_per_second", s.bytes_per_second},
          {"hrtf", s.hrtf},
          {"heard", heard}};
}

void report_voice(const VoiceStats& s, const std::string& json_path) {
  std::printf("voice: sent %llu packets (%.0f bytes/s)%s\n",
              static_cast<unsigned long long>(s.packets_sent), s.bytes_per_second,
              s.hrtf ? ", voices placed with HRTF" : "");
  for (const HeardVoice& h : s.heard)
    std::printf(
        "  heard %-20s %6llu packets, mouth-to-ear p50 %5.0f ms p99 %5.0f ms, %.1f %% "
        "concealed%s\n",
        printable(h.name, 20).c_str(), static_cast<unsigned long long>(h.stream.packets),
        h.latency_ms_p50, h.latency_ms_p99, h.stream.concealed_percent(), h.muted ? ", muted" : "");
  std::fflush(stdout);
  if (json_path.empty()) return;
  std::ofstream out(json_path);
  out << to_json(s).dump(2) << "\n";
  if (!out) throw Error("cannot write " + json_path);
}

}  // namespace volcast::voice
