// volcast bench --paths: the real two-camera site to one viewer over impaired paths (network
// namespaces and the userspace relay of impaired_link.hpp; needs root), a viewer pinned to the old
// default tier beside one adapting along the server's ladder, in the same run.
#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <nlohmann/json.hpp>

#include "volcast/bench/bench.hpp"
#include "volcast/bench/impaired_link.hpp"
#include "volcast/capture/real_sites.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/net/stream/client.hpp"
#include "volcast/pipeline/frame_feed.hpp"
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
  c.color_quality = adapt ? 0 : 90;
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
    const std::string tier = tier_label(client->tier());
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
  if (!a.json.empty()) {
    nlohmann::json j;
    j["paths"] = rows;
    const fs::path path = a.json;
    if (path.has_parent_path()) fs::create_directories(path.parent_path());
    std::ofstream(path) << j.dump(2) << "\n";
    std::printf("wrote %s\n", path.c_str());
  }
  return 0;
}

}  // namespace volcast
