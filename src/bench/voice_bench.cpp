// volcast bench --voice: voices through the session service on loopback (TLS), real recorded
// speech (shared data speech/) from microphone files: mouth-to-ear latency (capture time of a
// frame's first sample -> the frame played at the listener), concealed frames, bytes per second
// per speaker, and the server's CPU forwarding 4 talkers to 16 participants. The talkers'
// microphones start 20 ms / talkers apart (4 talkers: 5 ms), not at the same instant.
#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "bench_session_site.hpp"
#include "volcast/audio/wav.hpp"
#include "volcast/bench/bench.hpp"
#include "volcast/capture/real_sites.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/net/stream/client.hpp"
#include "volcast/pipeline/sender.hpp"
#include "volcast/pipeline/session_client.hpp"
#include "volcast/session/hub.hpp"
#include "volcast/voice/voice_link.hpp"

namespace volcast {
namespace {
namespace fs = std::filesystem;

struct VoiceRow {
  std::string name;
  int participants = 0, talkers = 0;
  double latency_ms_p50 = 0, latency_ms_p99 = 0;  ///< median p50, worst p99 over (talker, listener)
  double concealed_percent = 0;                   ///< worst over (talker, listener)
  double bytes_per_second = 0;                    ///< per talker, mean
  double server_cpu_percent = 0;                  ///< the server's threads serving participants
  double writes_per_second = 0;  ///< the server's writes of session messages, all participants
  uint64_t packets_forwarded = 0;
};

// Speech `seconds` long: the shared recordings one after another (0.3 s apart), repeated.
std::vector<float> speech_for(const fs::path& data, double seconds, int first) {
  const char* names[] = {"Front_Center", "Front_Left", "Front_Right", "Side_Left", "Side_Right"};
  std::vector<float> out;
  for (int i = first; out.size() < size_t(seconds * audio::kSampleRate); ++i) {
    const std::vector<float> s =
        audio::read_voice(data / "speech" / (std::string(names[i % 5]) + ".wav"));
    out.insert(out.end(), s.begin(), s.end());
    out.resize(out.size() + size_t(0.3 * audio::kSampleRate), 0.0f);
  }
  return out;
}

VoiceRow measure_voice(const std::string& name, const fs::path& data, const fs::path& dir,
                       int participants, int talkers, double seconds, double hold_ms) {
  VoiceRow row;
  row.name = name;
  row.participants = participants;
  row.talkers = talkers;
  SitePlayer site(two_camera_site(data), 30);  // cameras announced, not streamed
  SessionHubConfig hub_config;
  hub_config.max_participants = participants + 1;  // and the OR site
  SessionHub hub(hub_config);
  ServerConfig config;
  config.port = 0;
  config.session = &hub;
  config.max_pending_per_address = 64;
  if (hold_ms >= 0) config.stream_coalesce_us = static_cast<int64_t>(hold_ms * 1000);
  Server server(site.cameras(), config);
  hub.attach(&server);
  const std::string link = server.join_link("127.0.0.1");
  struct Person {
    std::unique_ptr<HeadlessParticipant> headless;
    std::unique_ptr<voice::VoiceLink> voice;
  };
  std::vector<std::unique_ptr<Person>> people;
  for (int i = 0; i < participants; ++i) {
    auto p = std::make_unique<Person>();
    SessionClientOptions o;
    o.participant.session = "bench";
    o.participant.name = "participant " + std::to_string(i + 1);
    o.drive_poses = false;
    p->headless = bench::join_bench(link, std::move(o));
    people.push_back(std::move(p));
  }
  for (int waited = 0; hub.members("bench").size() < size_t(participants) + 1; ++waited) {
    if (waited == 1000) throw Error("bench --voice: the participants did not all join in 20 s");
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // everyone sees everyone
  const int64_t start = wall_clock_us() + 200'000;
  for (int i = 0; i < participants; ++i) {
    voice::VoiceConfig v;
    v.spatial = false;  // the listeners' mixing is not what is measured
    if (i < talkers) {
      audio::Pcm mic;
      mic.samples = speech_for(data, seconds + 1, i);
      const fs::path file = dir / fmt::format("mic{}.wav", i);
      audio::write_wav(file, mic);
      v.mic = file.string();
      // Real talkers do not start their 20 ms frames at the same instant: spread their starts
      // evenly over one frame (4 talkers: 0, 5, 10 and 15 ms), so their packets reach the
      // server apart as they would, not as one burst per frame.
      v.mic_start_us = start + int64_t(i) * 20'000 / talkers;
    }
    people[size_t(i)]->voice =
        std::make_unique<voice::VoiceLink>(people[size_t(i)]->headless->participant(), v);
  }
  const auto serving = [&] {
    double ms = 0;
    for (const ViewerReport& v : server.viewers()) ms += v.send_cpu_ms;
    return ms;
  };
  const auto writes = [&] {
    uint64_t n = 0;
    for (const ViewerReport& v : server.viewers()) n += v.session_flushes;
    return n;
  };
  std::this_thread::sleep_for(std::chrono::milliseconds(700));  // the jitter buffers settle
  const double serve0 = serving();
  const uint64_t writes0 = writes();
  const uint64_t out0 = hub.stats().voice_out;
  const auto t0 = std::chrono::steady_clock::now();
  std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  row.server_cpu_percent = 0.1 * (serving() - serve0) / wall;
  row.writes_per_second = static_cast<double>(writes() - writes0) / wall;
  row.packets_forwarded = hub.stats().voice_out - out0;
  std::vector<double> p50;
  for (auto& p : people) {
    const voice::VoiceStats s = p->voice->stats();
    if (s.packets_sent > 0) row.bytes_per_second += s.bytes_per_second / talkers;
    for (const voice::HeardVoice& h : s.heard) {
      if (h.stream.frames_from_packets == 0) continue;
      p50.push_back(h.latency_ms_p50);
      row.latency_ms_p99 = std::max(row.latency_ms_p99, h.latency_ms_p99);
      row.concealed_percent = std::max(row.concealed_percent, h.stream.concealed_percent());
    }
  }
  for (auto& p : people) p->voice->stop();
  for (auto& p : people) p->headless->end();  // before the server stops
  for (auto& p : people)
    if (!p->headless->error().empty())
      throw Error("bench participant failed: " + p->headless->error());
  hub.attach(nullptr);
  server.stop();
  std::sort(p50.begin(), p50.end());
  row.latency_ms_p50 = p50.empty() ? 0 : p50[p50.size() / 2];
  return row;
}

}  // namespace

int run_voice_bench(const BenchArgs& a) {
  const auto data = find_data(a.data);
  if (!data) throw Error("bench --voice: the real recordings were not found (--data DIR)");
  if (!(a.server_seconds > 0)) throw Error("--server-seconds must be positive");
  spdlog::set_level(spdlog::level::warn);
  const fs::path dir = fs::temp_directory_path() / fmt::format("volcast-bench-voice-{}", getpid());
  fs::create_directories(dir);
  struct Config {
    const char* name;
    int participants, talkers;
  };
  const Config configs[] = {{"loopback, 1 talker -> 1 listener", 2, 1},
                            {"16 participants, 4 talking", 16, 4}};
  const double hold_ms = a.voice_hold_ms >= 0
                             ? a.voice_hold_ms
                             : static_cast<double>(ServerConfig{}.stream_coalesce_us) / 1000;
  std::printf("%-34s %10s %10s %10s %12s %12s %11s %9s\n", "configuration", "m2e p50", "m2e p99",
              "concealed", "bytes/s/spk", "forwarded", "server CPU", "writes/s");
  nlohmann::json rows = nlohmann::json::array();
  int n = 0;
  for (const Config& c : configs) {
    if (isatty(STDERR_FILENO)) std::fprintf(stderr, "[%d/2] %s...\r", ++n, c.name);
    const VoiceRow r =
        measure_voice(c.name, *data, dir, c.participants, c.talkers, a.server_seconds, hold_ms);
    std::printf("%-34s %8.1fms %8.1fms %9.2f%% %12.0f %12llu %10.2f%% %9.0f\n", r.name.c_str(),
                r.latency_ms_p50, r.latency_ms_p99, r.concealed_percent, r.bytes_per_second,
                static_cast<unsigned long long>(r.packets_forwarded), r.server_cpu_percent,
                r.writes_per_second);
    std::fflush(stdout);
    rows.push_back({{"configuration", r.name},
                    {"participants", r.participants},
                    {"talkers", r.talkers},
                    {"mouth_to_ear_ms_p50", r.latency_ms_p50},
                    {"mouth_to_ear_ms_p99", r.latency_ms_p99},
                    {"concealed_percent", r.concealed_percent},
                    {"bytes_per_second_per_speaker", r.bytes_per_second},
                    {"packets_forwarded", r.packets_forwarded},
                    {"server_cpu_percent_of_one_core", r.server_cpu_percent},
                    {"server_writes_per_second", r.writes_per_second},
                    {"voice_hold_ms", hold_ms}});
  }
  fs::remove_all(dir);
  std::printf(
      "m2e: mouth-to-ear, a frame's capture (its first sample) -> played at the listener (file "
      "devices: no device latency), median of the p50s, worst p99; concealed: worst share of "
      "talking frames rebuilt by FEC or PLC; server CPU: the server's threads serving the "
      "participants (reading, forwarding and writing the voice packets), %% of one core; "
      "writes/s: the server's writes of session messages to all participants (a listener's "
      "voice packets wait up to %.0f ms for the other talkers', to go out in one write: "
      "--voice-hold-ms); the talkers' microphones start 20 ms / talkers apart (4 talkers: 5 "
      "ms), as real talkers' frames are not aligned\n",
      hold_ms);
  if (!a.json.empty()) {
    nlohmann::json j;
    j["voice"] = rows;
    const fs::path path = a.json;
    if (path.has_parent_path()) fs::create_directories(path.parent_path());
    std::ofstream(path) << j.dump(2) << "\n";
    std::printf("wrote %s\n", path.c_str());
  }
  return 0;
}

}  // namespace volcast
