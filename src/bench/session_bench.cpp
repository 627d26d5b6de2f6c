// volcast bench --session: the virtual OR's session service on loopback (TLS): the round trip of
// a pose (sent -> seen by another participant -> echoed back), pose rates and ages at every
// receiver, camera-avatar rate and latency, and the server's CPU per participant.
#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "bench_session_site.hpp"
#include "volcast/bench/bench.hpp"
#include "volcast/capture/real_sites.hpp"
#include "volcast/core/error.hpp"
#include "volcast/net/stream/client.hpp"
#include "volcast/pipeline/sender.hpp"
#include "volcast/pipeline/session_client.hpp"
#include "volcast/session/hub.hpp"

namespace volcast {
namespace {
namespace fs = std::filesystem;

struct SessionRow {
  std::string name;
  int participants = 0, cameras = 0, avatars = 0;
  double round_trip_ms_p50 = 0, round_trip_ms_p99 = 0;
  size_t round_trip_samples = 0;
  double pose_rate_hz_min = 0, pose_age_ms_p50 = 0, pose_age_ms_p99 = 0;
  double avatar_fps_min = 0, avatar_latency_ms_p50 = 0, avatar_latency_ms_p99 = 0;
  double serving_cpu_percent = 0;  ///< all participants' serving threads on the server
  double encode_cpu_percent = 0;   ///< the site's tier encoding (shared by all)
};

double median_of(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// One configuration: the real site `sources` at 30 fps, `participants` joining session "bench",
// the first `avatars` of them uploading the hands sequence as their camera avatar.
SessionRow measure_session(const std::string& name,
                           std::vector<std::unique_ptr<FrameSource>> sources, int participants,
                           int avatars, const fs::path& hands, double seconds, bool stream_site) {
  SessionRow row;
  row.name = name;
  row.participants = participants;
  row.cameras = static_cast<int>(sources.size());
  row.avatars = avatars;
  bench::BenchSite site(std::move(sources), stream_site);
  std::vector<std::unique_ptr<HeadlessParticipant>> people;
  for (int i = 0; i < participants; ++i) {
    SessionClientOptions o;
    o.participant.session = "bench";
    o.participant.name = "participant " + std::to_string(i + 1);
    o.participant.echo_every = 1;  // every pose is a round-trip sample: a steadier p99
    if (i < avatars) {
      o.camera_source = hands;
      o.camera_options.intrinsics = Intrinsics{0, 0, 460, 460, 320, 180};
    }
    people.push_back(bench::join_bench(site.link, std::move(o)));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // joins, first frames
  const auto serving = [&] {
    double ms = 0;
    for (const ViewerReport& v : site.server.viewers()) ms += v.send_cpu_ms;
    return ms;
  };
  const auto encoding = [&] {
    double ms = 0;
    for (const TierReport& t : site.server.tiers())
      ms += t.encode_ms_mean * double(t.frames_encoded);
    return ms;
  };
  const double serve0 = serving(), encode0 = encoding();
  const auto t0 = std::chrono::steady_clock::now();
  std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  row.serving_cpu_percent = 0.1 * (serving() - serve0) / wall;
  row.encode_cpu_percent = 0.1 * (encoding() - encode0) / wall;
  std::vector<double> rtt50, rtt99, age50, age99, lat50, lat99;
  row.pose_rate_hz_min = 1e9;
  row.avatar_fps_min = avatars > 0 ? 1e9 : 0;
  for (auto& p : people) {
    const ParticipantStats s = p->participant().stats();
    rtt50.push_back(s.round_trip_ms_p50);
    rtt99.push_back(s.round_trip_ms_p99);
    row.round_trip_samples += s.round_trip_samples;
    for (const RemoteStats& o : s.others) {
      if (o.name == "OR site") continue;
      row.pose_rate_hz_min = std::min(row.pose_rate_hz_min, o.pose_rate_hz);
      age50.push_back(o.pose_age_ms_p50);
      age99.push_back(o.pose_age_ms_p99);
      if (o.avatar_frames_received > 0) {
        row.avatar_fps_min = std::min(row.avatar_fps_min, o.avatar_fps);
        lat50.push_back(o.avatar_latency_ms_p50);
        lat99.push_back(o.avatar_latency_ms_p99);
      }
    }
  }
  bench::end_bench(people);
  site.stop();
  // Medians over participants of each participant's percentile; the worst p99.
  row.round_trip_ms_p50 = median_of(rtt50);
  row.round_trip_ms_p99 = rtt99.empty() ? 0 : *std::max_element(rtt99.begin(), rtt99.end());
  row.pose_age_ms_p50 = median_of(age50);
  row.pose_age_ms_p99 = age99.empty() ? 0 : *std::max_element(age99.begin(), age99.end());
  row.avatar_latency_ms_p50 = median_of(lat50);
  row.avatar_latency_ms_p99 = lat99.empty() ? 0 : *std::max_element(lat99.begin(), lat99.end());
  return row;
}

}  // namespace

int run_session_bench(const BenchArgs& a) {
  const auto data = find_data(a.data);
  if (!data) throw Error("bench --session: the real recordings were not found (--data DIR)");
  if (!(a.server_seconds > 0)) throw Error("--server-seconds must be positive");
  spdlog::set_level(spdlog::level::warn);
  struct Config {
    const char* name;
    int participants, avatars;
    bool stream_site;
  };
  const Config configs[] = {{"2 participants, site idle", 2, 0, false},
                            {"2 participants + OR's 2 cameras", 2, 0, true},
                            {"8 participants + OR's 2 cameras", 8, 0, true},
                            {"4 camera avatars + OR's 2 cameras", 4, 4, true}};
  std::printf("%-36s %8s %8s %8s %10s %9s %9s %9s %9s %10s %10s\n", "configuration", "rtt p50",
              "rtt p99", "samples", "pose Hz min", "age p50", "age p99", "avatar fps", "avat p50",
              "serve CPU", "per person");
  nlohmann::json rows = nlohmann::json::array();
  int n = 0;
  for (const Config& c : configs) {
    if (isatty(STDERR_FILENO)) std::fprintf(stderr, "[%d/3] %s...\r", ++n, c.name);
    const SessionRow r = measure_session(c.name, two_camera_site(*data), c.participants, c.avatars,
                                         *data / kHandsSet, a.server_seconds, c.stream_site);
    std::printf("%-36s %6.2fms %6.2fms %8zu %10.1f %7.2fms %7.2fms %9.1f %7.1fms %9.1f%% %9.1f%%\n",
                r.name.c_str(), r.round_trip_ms_p50, r.round_trip_ms_p99, r.round_trip_samples,
                r.pose_rate_hz_min, r.pose_age_ms_p50, r.pose_age_ms_p99, r.avatar_fps_min,
                r.avatar_latency_ms_p50, r.serving_cpu_percent,
                r.serving_cpu_percent / r.participants);
    std::fflush(stdout);
    rows.push_back({{"configuration", r.name},
                    {"participants", r.participants},
                    {"site_cameras", r.cameras},
                    {"site_streaming", c.stream_site},
                    {"camera_avatars", r.avatars},
                    {"session_round_trip_ms_p50", r.round_trip_ms_p50},
                    {"session_round_trip_ms_p99", r.round_trip_ms_p99},
                    {"round_trip_samples", r.round_trip_samples},
                    {"pose_rate_hz_min", r.pose_rate_hz_min},
                    {"pose_age_ms_p50", r.pose_age_ms_p50},
                    {"pose_age_ms_p99", r.pose_age_ms_p99},
                    {"avatar_fps_min", r.avatar_fps_min},
                    {"avatar_latency_ms_p50", r.avatar_latency_ms_p50},
                    {"avatar_latency_ms_p99", r.avatar_latency_ms_p99},
                    {"serving_cpu_percent", r.serving_cpu_percent},
                    {"serving_cpu_percent_per_participant", r.serving_cpu_percent / r.participants},
                    {"site_encode_cpu_percent", r.encode_cpu_percent}});
  }
  std::printf(
      "rtt: a participant's pose -> seen by another -> echoed back (every pose; median of the "
      "participants' p50, worst p99); age: pose time stamp -> received (server clock); serve CPU: "
      "the server threads serving the participants (session and stream), all together and per "
      "participant; the site's tier encoding is apart\n");
  if (!a.json.empty()) {
    nlohmann::json j;
    j["session"] = rows;
    const fs::path path = a.json;
    if (path.has_parent_path()) fs::create_directories(path.parent_path());
    std::ofstream(path) << j.dump(2) << "\n";
    std::printf("wrote %s\n", path.c_str());
  }
  return 0;
}

}  // namespace volcast
