// volcast bench --paths: the real two-camera site to one viewer over impaired paths (network
// namespaces and the userspace relay of impaired_link.hpp; needs root), a viewer pinned to the old
// default tier beside one adapting along the server's ladder, in the same run.
#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "volcast/bench/bench.hpp"
#include "volcast/bench/impaired_link.hpp"
#include "volcast/capture/real_sites.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/net/stream/client.hpp"
#include "volcast/pipeline/frame_feed.hpp"
#include "volcast/pipeline/receiver.hpp"
#include "volcast/pipeline/sender.hpp"
#include "volcast/pipeline/stage_stats.hpp"

namespace volcast {
namespace {
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

struct PathCase {
  const char* name;
  LinkImpairment start;           // both directions
  double step_to_bits_per_s = 0;  // > 0: the downstream rate drops to this after the first part
};

struct PathResult {
  double fps = 0, p50 = 0, p99 = 0;
  double recovery_s = -1;          // step paths: from the step until latency stays under 250 ms
  std::vector<std::string> tiers;  // in the order used
  nlohmann::json switches = nlohmann::json::array();
  std::vector<double> kilobytes_per_s;  // per camera (KiB/s, the paper's kB), over the measure
};

// One viewer (pinned to volcast/jpeg at quality 90, or adapting) for 1 s of warm-up and `seconds`
// measured; a step path runs 3 s at its first rate first, then measures after the step.
PathResult run_path(const fs::path& data, const PathCase& p, bool adapt, double seconds) {
  std::string why;
  auto link = ImpairedLink::create(p.start, &why);
  if (!link) throw Error("bench --paths: cannot make the impaired link: " + why);
  SitePlayer site(two_camera_site(data), 30);
  ServerConfig config;
  config.bind_address = link->server_address();
  config.port = 0;
  auto server =
      link->in_server_namespace([&] { return std::make_unique<Server>(site.cameras(), config); });
  site.start(*server);
  ClientConfig c = client_config_from_link(server->join_link(link->server_address()));
  c.decode = false;  // the path and the server are measured, not this machine's decoding
  c.adapt = adapt;
  c.tier.color_quality = adapt ? 0 : 90;
  auto client = link->in_client_namespace([&] { return std::make_unique<Client>(c); });
  const auto start = Clock::now();
  const double before = p.step_to_bits_per_s > 0 ? 3.0 : 0.0;
  const auto step_at = start + std::chrono::duration<double>(1.0 + before);
  const auto end = step_at + std::chrono::duration<double>(seconds);
  bool stepped = p.step_to_bits_per_s <= 0;
  PathResult r;
  std::vector<double> latency;
  std::vector<std::pair<double, double>> after_step;  // (s since the step, latency ms)
  std::vector<double> bytes(site.cameras().size(), 0);
  uint64_t frames = 0;
  ReceivedFrameSet rx;
  while (Clock::now() < end) {
    if (!stepped && Clock::now() >= step_at) {
      LinkImpairment down = p.start;
      down.rate_bits_per_s = p.step_to_bits_per_s;
      link->set_impairment(down, p.start);
      stepped = true;
    }
    if (!client->receive(rx)) throw Error("bench --paths: the server closed the stream");
    const std::string tier = to_string(client->tier().tier);
    if (r.tiers.empty() || r.tiers.back() != tier) r.tiers.push_back(tier);
    const auto now = Clock::now();
    if (now < step_at) continue;
    const double ms = double(rx.times.received_us - rx.times.capture_us) / 1000;
    latency.push_back(ms);
    after_step.emplace_back(std::chrono::duration<double>(now - step_at).count(), ms);
    ++frames;
    for (size_t i = 0; i < bytes.size() && i < rx.depth_bytes.size(); ++i)
      bytes[i] += double(rx.depth_bytes[i] + rx.color_bytes[i]);
  }
  r.fps = double(frames) / seconds;
  r.p50 = percentile(latency, 0.5);
  r.p99 = percentile(latency, 0.99);
  for (double b : bytes) r.kilobytes_per_s.push_back(b / 1024 / seconds);
  if (p.step_to_bits_per_s > 0) {  // the last frame set over 250 ms, and the step
    double last_late = 0;
    for (const auto& [t, ms] : after_step)
      if (ms > 250) last_late = t;
    r.recovery_s = last_late;
  }
  const int64_t wall_start =
      wall_clock_us() -
      std::chrono::duration_cast<std::chrono::microseconds>(Clock::now() - start).count();
  for (const auto& v : server->viewers())
    for (const auto& s : v.switches)
      r.switches.push_back({{"t_s", double(s.time_us - wall_start) / 1e6},
                            {"from", s.from},
                            {"to", s.to},
                            {"reason", s.reason}});
  client->close();
  site.stop();
  server->stop();
  return r;
}

// A cut path: the real two-camera site to a viewer (run_viewer, as `volcast view`: decoding, a
// presenter that draws nothing but notes the age of each frame set it is handed), the path cut
// (every packet lost both ways) for `cut_s` after 3 s, then whole again for `after_s`. Before:
// no reconnecting and the old 10 s receive timeout; now: reconnecting after 2 s of silence.
struct CutResult {
  bool survived = false;       // still receiving at the end
  std::string ended;           // how it ended (to_string(ViewerEnd))
  double back_s = -1;          // from the path's return to the first frame set drawn under 250 ms
  double first_age_ms = -1;    // the age of the first frame set drawn after the path came back
  double p99_after_ms = 0;     // age of the frame sets drawn after the path came back, p99
  uint64_t stale_drawn = 0;    // drawn after the path came back, over 1 s old
  uint64_t stale_dropped = 0;  // not drawn: over 1 s old when they arrived
  size_t reconnects = 0;
};

CutResult run_cut(const fs::path& data, double cut_s, bool reconnect, double after_s) {
  std::string why;
  auto link = ImpairedLink::create(LinkImpairment{}, &why);
  if (!link) throw Error("bench --paths: cannot make the impaired link: " + why);
  SitePlayer site(two_camera_site(data), 30);
  ServerConfig config;
  config.bind_address = link->server_address();
  config.port = 0;
  auto server =
      link->in_server_namespace([&] { return std::make_unique<Server>(site.cameras(), config); });
  site.start(*server);
  ViewerOptions opt;
  opt.client = client_config_from_link(server->join_link(link->server_address()));
  opt.client.adapt = true;
  opt.client.receive_timeout_ms = reconnect ? 2000 : 10000;
  opt.reconnect = reconnect;
  if (reconnect) opt.stale_ms = 1000;
  opt.seconds = 3 + cut_s + after_s;
  std::mutex mutex;
  std::vector<std::pair<Clock::time_point, double>> drawn;  // (when, age ms)
  opt.presenter = [&](FrameFeed& feed, ViewerResult&) {
    std::vector<std::shared_ptr<const CameraFrame>> frames;
    while (!feed.finished())
      if (feed.next(frames, std::chrono::milliseconds(20))) {
        const int64_t captured = feed.live().newest_capture_us;
        std::lock_guard lock(mutex);
        drawn.emplace_back(Clock::now(), double(wall_clock_us() - captured) / 1000);
      }
  };
  ViewerResult result;
  const auto start = Clock::now();
  std::thread cutter([&] {
    std::this_thread::sleep_until(start + std::chrono::seconds(3));
    LinkImpairment cut;
    cut.loss = 1;
    link->set_impairment(cut, cut);
    std::this_thread::sleep_until(start + std::chrono::duration<double>(3 + cut_s));
    link->set_impairment({}, {});
  });
  link->in_client_namespace([&] {
    try {
      result = run_viewer(opt);
    } catch (const ViewerError& e) {
      result = e.result();
    }
  });
  cutter.join();
  const auto back = start + std::chrono::duration<double>(3 + cut_s);
  CutResult r;
  r.ended = to_string(result.ended);
  r.reconnects = result.outages.size();
  r.stale_dropped = result.frames_stale;
  std::vector<double> ages;
  std::lock_guard lock(mutex);
  for (const auto& [t, age] : drawn) {
    if (t < back) continue;
    if (r.first_age_ms < 0) r.first_age_ms = age;
    if (r.back_s < 0 && age < 250) r.back_s = std::chrono::duration<double>(t - back).count();
    ages.push_back(age);
    r.stale_drawn += age > 1000;
  }
  r.p99_after_ms = percentile(ages, 0.99);
  r.survived = !drawn.empty() && Clock::now() - drawn.back().first < std::chrono::seconds(2) &&
               drawn.back().first > back;
  site.stop();
  server->stop();
  return r;
}

}  // namespace

int run_paths_bench(const BenchArgs& a) {
  const auto data = find_data(a.data);
  if (!data) throw Error("bench --paths: the real recordings were not found (--data DIR)");
  if (!(a.server_seconds > 0)) throw Error("--server-seconds must be positive");
  spdlog::set_level(spdlog::level::warn);
  const PathCase paths[] = {
      {"unlimited (namespaces only)", {}},
      {"20 Mbit/s + 50 ms RTT", {.one_way_delay_us = 25'000, .rate_bits_per_s = 20e6}},
      {"50 ms RTT + 2% loss", {.one_way_delay_us = 25'000, .loss = 0.02}},
      {"100 -> 20 Mbit/s (50 ms RTT)",
       {.one_way_delay_us = 25'000, .rate_bits_per_s = 100e6},
       20e6},
  };
  std::printf(
      "2 real cameras (hands + Azure Kinect) at 30 fps to one receive-only viewer over TLS; pinned "
      "= volcast/jpeg/90 (the old default), adaptive = the server's ladder; %.0f s each\n",
      a.server_seconds);
  std::printf("%-30s %-9s %6s %9s %9s %9s %11s  %s\n", "path", "viewer", "fps", "lat p50",
              "lat p99", "recovery", "KiB/s/cam", "tiers used");
  nlohmann::json rows = nlohmann::json::array();
  const size_t total = std::size(paths) * 2;
  size_t done = 0;
  for (const PathCase& p : paths)
    for (const bool adapt : {false, true}) {
      if (isatty(STDERR_FILENO))
        std::fprintf(stderr, "[%zu/%zu] %s, %s...\r", ++done, total, p.name,
                     adapt ? "adaptive" : "pinned");
      const PathResult r = run_path(*data, p, adapt, a.server_seconds);
      std::string tiers;
      for (const auto& t : r.tiers) tiers += (tiers.empty() ? "" : " > ") + t;
      std::string kib;
      for (double k : r.kilobytes_per_s) kib += (kib.empty() ? "" : "/") + fmt::format("{:.0f}", k);
      std::printf("%-30s %-9s %6.1f %7.1fms %7.1fms %9s %11s  %s\n", p.name,
                  adapt ? "adaptive" : "pinned", r.fps, r.p50, r.p99,
                  r.recovery_s < 0 ? "-" : fmt::format("{:.2f}s", r.recovery_s).c_str(),
                  kib.c_str(), tiers.c_str());
      std::fflush(stdout);
      rows.push_back({{"path", p.name},
                      {"viewer", adapt ? "adaptive" : "pinned"},
                      {"fps", r.fps},
                      {"latency_ms_p50", r.p50},
                      {"latency_ms_p99", r.p99},
                      {"recovery_s", r.recovery_s},
                      {"kib_per_s_per_camera", r.kilobytes_per_s},
                      {"tiers", r.tiers},
                      {"switches", r.switches}});
    }
  std::printf(
      "recovery: on the step path, seconds from the step to the last frame set over 250 ms.\n");

  std::printf(
      "\ncut paths: every packet lost both ways for N s, then whole for 8 s; before = no "
      "reconnecting, 10 s receive timeout; now = reconnecting after 2 s of silence\n");
  std::printf("%-8s %-7s %-16s %10s %12s %12s %12s %12s %10s\n", "cut", "viewer", "ended", "back",
              "first age", "age p99", "stale drawn", "stale skip", "reconnects");
  nlohmann::json cuts = nlohmann::json::array();
  for (const double cut_s : {6.0, 12.0})
    for (const bool reconnect : {false, true}) {
      const CutResult r = run_cut(*data, cut_s, reconnect, 8);
      std::printf("%-8s %-7s %-16s %10s %10.0fms %10.0fms %12llu %12llu %10zu\n",
                  fmt::format("{:.0f} s", cut_s).c_str(), reconnect ? "now" : "before",
                  r.ended.c_str(),
                  r.back_s < 0 ? "never" : fmt::format("{:.2f}s", r.back_s).c_str(), r.first_age_ms,
                  r.p99_after_ms, static_cast<unsigned long long>(r.stale_drawn),
                  static_cast<unsigned long long>(r.stale_dropped), r.reconnects);
      std::fflush(stdout);
      cuts.push_back({{"cut_s", cut_s},
                      {"viewer", reconnect ? "reconnecting" : "before"},
                      {"ended", r.ended},
                      {"back_s", r.back_s},
                      {"first_age_ms", r.first_age_ms},
                      {"age_ms_p99_after", r.p99_after_ms},
                      {"stale_drawn", r.stale_drawn},
                      {"stale_dropped", r.stale_dropped},
                      {"reconnects", r.reconnects}});
    }
  std::printf(
      "back: from the path's return to the first frame set drawn under 250 ms old; first age: "
      "the first one drawn after it.\n");
  if (!a.json.empty()) {
    nlohmann::json j;
    j["paths"] = rows;
    j["cuts"] = cuts;
    const fs::path path = a.json;
    if (path.has_parent_path()) fs::create_directories(path.parent_path());
    std::ofstream(path) << j.dump(2) << "\n";
    std::printf("wrote %s\n", path.c_str());
  }
  return 0;
}

}  // namespace volcast
