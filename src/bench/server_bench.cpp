// volcast bench --server: the server's cost per viewer, measured with receive-only viewers.
#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "volcast/bench/bench.hpp"
#include "volcast/capture/real_sites.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/net/stream/client.hpp"
#include "volcast/pipeline/sender.hpp"
#include "volcast/pipeline/stage_stats.hpp"
#include "volcast/record/recorder.hpp"

namespace volcast {
namespace {
namespace fs = std::filesystem;

// User + system CPU seconds of the process (RUSAGE_SELF) or the calling thread (RUSAGE_THREAD).
double cpu_seconds(int who) {
  rusage u{};
  getrusage(who, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec) / 1e6;
}

struct ViewerFigures {
  uint64_t frames = 0;
  std::vector<double> latency_ms;  // capture -> message read
  double cpu_s = 0;                // this viewer thread's CPU time (subtracted from the server's)
  std::string error;
};

struct Row {
  int cameras = 0, viewers = 0;
  std::string tier;
  bool tls = true;
  double fps_min = 0, latency_ms_p50 = 0, latency_ms_p99 = 0, server_cpu_percent = 0;
  double send_cpu_percent = 0;  ///< the threads serving the viewers (ViewerReport::send_cpu_ms)
  // With a recorder: what it wrote while measured.
  double recorded_mb_per_minute_per_camera = 0;
  uint64_t recorded_frame_sets = 0, recorder_dropped = 0;
};

// A recorder for measure(): tier "DEPTH/COLOR" into `path` (replaced).
struct RecordTap {
  std::string depth, color;
  fs::path path;
};

// The CPU (ms) the server's viewer threads have spent so far, over all viewers.
double send_cpu_ms(const Server& server) {
  double ms = 0;
  for (const ViewerReport& v : server.viewers()) ms += v.send_cpu_ms;
  return ms;
}

// One configuration: a site of the given sources, `viewers` receive-only viewers on one tier.
// With `tls`, over TLS 1.3 (the default transport); else plain TCP on loopback (--insecure).
Row measure(std::vector<std::unique_ptr<FrameSource>> sources, int viewers,
            const std::string& depth, const std::string& color, double seconds, bool tls,
            const RecordTap* record = nullptr) {
  const int cameras = static_cast<int>(sources.size());
  SitePlayer site(std::move(sources), 30);
  ServerConfig config;
  config.port = 0;
  config.max_viewers = std::max(16, viewers);
  config.insecure = !tls;
  config.max_pending_per_address = 64;  // every bench viewer joins at once from 127.0.0.1
  Server server(site.cameras(), config);
  const std::string link = server.join_link("127.0.0.1");
  std::optional<BackgroundRecorder> recorder;
  if (record) {
    RecordingStream stream;
    stream.tier = {record->depth, record->color};
    stream.welcome = {site.cameras(), wall_clock_us()};
    recorder.emplace(record->path, stream, RecordingWriterOptions{.overwrite = true});
    server.add_tier_tap(stream.tier, [&recorder](const TierFrameSet& f) { recorder->push(f); });
  }
  site.start(server);
  std::vector<ViewerFigures> figures(static_cast<size_t>(viewers));
  std::atomic<bool> measuring{false}, done{false};
  std::vector<std::thread> threads;
  for (int i = 0; i < viewers; ++i)
    threads.emplace_back([&, i] {
      ViewerFigures& f = figures[static_cast<size_t>(i)];
      try {
        ClientConfig c = client_config_from_link(link);
        c.tier = {depth, color};
        c.decode = false;  // read and acknowledge only: the figure is the server's
        Client client(c);
        ReceivedFrameSet rx;
        double cpu_start = 0;
        bool counting = false;
        while (!done && client.receive(rx)) {
          if (measuring && !counting) {
            counting = true;
            cpu_start = cpu_seconds(RUSAGE_THREAD);
          }
          if (!counting) continue;
          ++f.frames;
          f.latency_ms.push_back(static_cast<double>(rx.times.received_us - rx.times.capture_us) /
                                 1000.0);
        }
        f.cpu_s = cpu_seconds(RUSAGE_THREAD) - cpu_start;
        client.close();
      } catch (const std::exception& e) {
        if (!done) f.error = e.what();  // after `done` the server's stop may cut a message short
      }
    });
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // join, key frames, warm-up
  const double cpu0 = cpu_seconds(RUSAGE_SELF), send0 = send_cpu_ms(server);
  const RecorderStats rec0 = recorder ? recorder->stats() : RecorderStats{};
  const auto t0 = std::chrono::steady_clock::now();
  measuring = true;
  std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
  done = true;
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const double cpu1 = cpu_seconds(RUSAGE_SELF), send1 = send_cpu_ms(server);
  const RecorderStats rec1 = recorder ? recorder->stats() : RecorderStats{};
  site.stop();
  server.stop();  // ends the viewers' connections
  for (auto& t : threads) t.join();
  if (recorder) {
    recorder->stop();
    if (!recorder->stats().error.empty()) throw Error(recorder->stats().error);
  }

  Row row;
  row.cameras = cameras;
  row.viewers = viewers;
  row.tier = depth + "/" + color;
  row.tls = tls;
  std::vector<double> all;
  double viewer_cpu = 0;
  row.fps_min = 1e9;
  for (const auto& f : figures) {
    if (!f.error.empty()) throw Error("bench viewer failed: " + f.error);
    row.fps_min = std::min(row.fps_min, static_cast<double>(f.frames) / wall);
    all.insert(all.end(), f.latency_ms.begin(), f.latency_ms.end());
    viewer_cpu += f.cpu_s;
  }
  row.latency_ms_p50 = percentile(all, 0.5);
  row.latency_ms_p99 = percentile(all, 0.99);
  // The process's CPU less the viewers' own threads: site reading, tier encoding, sending.
  row.server_cpu_percent = 100 * std::max(0.0, cpu1 - cpu0 - viewer_cpu) / wall;
  row.send_cpu_percent = 0.1 * (send1 - send0) / wall;
  if (recorder) {
    row.recorded_frame_sets = rec1.frame_sets - rec0.frame_sets;
    row.recorder_dropped = rec1.dropped - rec0.dropped;
    row.recorded_mb_per_minute_per_camera =
        static_cast<double>(rec1.bytes - rec0.bytes) / 1e6 * 60 / wall / cameras;
  }
  return row;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n == 0 ? 0 : n % 2 ? v[n / 2] : (v[n / 2 - 1] + v[n / 2]) / 2;
}

std::string runs_text(const std::vector<double>& v, const char* format) {
  std::string out;
  for (double x : v) out += (out.empty() ? "" : " ") + fmt::format(fmt::runtime(format), x);
  return out;
}

// Writes {key: rows} to `path` (its folder made), unless `path` is empty.
void write_rows_json(const std::string& path, const char* key, const nlohmann::json& rows) {
  if (path.empty()) return;
  nlohmann::json j;
  j[key] = rows;
  const fs::path p = path;
  if (p.has_parent_path()) fs::create_directories(p.parent_path());
  std::ofstream(p) << j.dump(2) << "\n";
  std::printf("wrote %s\n", p.c_str());
}

}  // namespace

int run_server_bench(const BenchArgs& a) {
  const auto data = find_data(a.data);
  if (!data) throw Error("bench --server: the real recordings were not found (--data DIR)");
  std::vector<int> viewer_counts = a.viewers.empty() ? std::vector<int>{1, 4, 8, 16} : a.viewers;
  for (int v : viewer_counts)
    if (v < 1 || v > 64) throw Error("--viewers must be 1..64");
  if (!(a.server_seconds > 0)) throw Error("--server-seconds must be positive");
  if (a.server_repeats < 1 || a.server_repeats > 20) throw Error("--server-repeats must be 1..20");
  spdlog::set_level(spdlog::level::warn);  // viewers connecting and leaving are not news here
  // Each configuration runs as TCP, TLS, TCP, TLS, ...: a pair shares the machine's state of the
  // moment (other load, clock), so the ratio of each pair is steadier than the ratio of averages.
  std::printf("%-8s %-8s %-14s %-5s %9s %9s %9s %11s %10s %9s %10s  %s\n", "cameras", "viewers",
              "tier", "link", "fps min", "lat p50", "lat p99", "server CPU", "TLS / TCP",
              "send CPU", "TLS / TCP", "per run (server CPU % or ratio)");
  nlohmann::json rows = nlohmann::json::array();
  const size_t total = 2 * viewer_counts.size() * static_cast<size_t>(a.server_repeats) * 2;
  size_t done = 0;
  for (int cameras : {2, 4})
    for (int viewers : viewer_counts) {
      std::vector<Row> runs[2];  // [0] TCP, [1] TLS
      std::vector<double> ratios, send_ratios;
      for (int r = 0; r < a.server_repeats; ++r)
        for (bool tls : {false, true}) {
          if (isatty(STDERR_FILENO))  // progress where a person watches; the table goes to stdout
            std::fprintf(stderr, "[%zu/%zu] %d cameras, %d viewers, %s, run %d...\r", ++done, total,
                         cameras, viewers, tls ? "TLS" : "TCP", r + 1);
          auto sources = cameras == 2 ? two_camera_site(*data) : four_camera_site(*data);
          runs[tls].push_back(
              measure(std::move(sources), viewers, "volcast", "jpeg", a.server_seconds, tls));
          if (tls) {
            ratios.push_back(runs[1].back().server_cpu_percent /
                             std::max(1e-9, runs[0].back().server_cpu_percent));
            send_ratios.push_back(runs[1].back().send_cpu_percent /
                                  std::max(1e-9, runs[0].back().send_cpu_percent));
          }
        }
      for (bool tls : {false, true}) {
        const std::vector<Row>& v = runs[tls];
        std::vector<double> cpu, send, fps, p50, p99;
        for (const Row& r : v) {
          cpu.push_back(r.server_cpu_percent);
          send.push_back(r.send_cpu_percent);
          fps.push_back(r.fps_min);
          p50.push_back(r.latency_ms_p50);
          p99.push_back(r.latency_ms_p99);
        }
        const double fps_min = *std::min_element(fps.begin(), fps.end());
        const std::string ratio = tls ? fmt::format("{:.2f}x", median(ratios)) : "";
        const std::string send_ratio = tls ? fmt::format("{:.2f}x", median(send_ratios)) : "";
        const std::string per_run = tls ? runs_text(ratios, "{:.2f}") : runs_text(cpu, "{:.0f}");
        std::printf("%-8d %-8d %-14s %-5s %9.1f %7.1fms %7.1fms %10.0f%% %10s %8.1f%% %10s  %s\n",
                    cameras, viewers, v[0].tier.c_str(), tls ? "TLS" : "TCP", fps_min, median(p50),
                    median(p99), median(cpu), ratio.c_str(), median(send), send_ratio.c_str(),
                    per_run.c_str());
        nlohmann::json row = {{"cameras", cameras},
                              {"viewers", viewers},
                              {"tier", v[0].tier},
                              {"transport", tls ? "tls" : "tcp"},
                              {"fps_min", fps_min},
                              {"latency_ms_p50", median(p50)},
                              {"latency_ms_p99", median(p99)},
                              {"server_cpu_percent", median(cpu)},
                              {"server_cpu_percent_runs", cpu},
                              {"send_cpu_percent", median(send)},
                              {"send_cpu_percent_runs", send}};
        if (tls) {
          row["tls_over_tcp"] = median(ratios);
          row["tls_over_tcp_runs"] = ratios;
          row["send_tls_over_tcp"] = median(send_ratios);
          row["send_tls_over_tcp_runs"] = send_ratios;
        }
        rows.push_back(row);
      }
      std::fflush(stdout);
    }
  write_rows_json(a.json, "server", rows);
  return 0;
}

int run_record_bench(const BenchArgs& a) {
  const auto data = find_data(a.data);
  if (!data) throw Error("bench --record: the real recordings were not found (--data DIR)");
  if (!(a.server_seconds > 0)) throw Error("--server-seconds must be positive");
  if (a.server_repeats < 1 || a.server_repeats > 20) throw Error("--server-repeats must be 1..20");
  spdlog::set_level(spdlog::level::warn);
  const fs::path dir = fs::temp_directory_path() / fmt::format("volcast-bench-record-{}", getpid());
  fs::create_directories(dir);
  // Configurations run in turn within each repeat, so each recording run has a baseline run of
  // the same moment: the added latency and CPU are the medians of those pairs' differences.
  struct Config {
    std::string name;
    std::optional<RecordTap> tap;
  };
  const std::vector<Config> configs = {
      {"no recorder", std::nullopt},
      {"record the viewers' tier (volcast/jpeg)", RecordTap{"volcast", "jpeg", dir / "same.vcr"}},
      {"record another tier (volcast-t/jpeg)", RecordTap{"volcast-t", "jpeg", dir / "other.vcr"}}};
  std::vector<std::vector<Row>> runs(configs.size());
  for (int r = 0; r < a.server_repeats; ++r)
    for (size_t c = 0; c < configs.size(); ++c) {
      if (isatty(STDERR_FILENO))
        std::fprintf(stderr, "[%zu/%zu] %s, run %d...\r", r * configs.size() + c + 1,
                     configs.size() * a.server_repeats, configs[c].name.c_str(), r + 1);
      runs[c].push_back(measure(two_camera_site(*data), 1, "volcast", "jpeg", a.server_seconds,
                                true, configs[c].tap ? &*configs[c].tap : nullptr));
    }
  std::printf("2 real cameras at 30 fps, 1 TLS viewer on volcast/jpeg, %d runs of %.0f s each\n",
              a.server_repeats, a.server_seconds);
  std::printf("%-42s %9s %9s %11s %12s %12s %14s %9s\n", "configuration", "lat p50", "lat p99",
              "server CPU", "added p50", "added CPU", "MB/min/camera", "dropped");
  nlohmann::json rows = nlohmann::json::array();
  for (size_t c = 0; c < configs.size(); ++c) {
    std::vector<double> p50, p99, cpu, added, added_cpu, mb;
    uint64_t dropped = 0, frames = 0;
    for (size_t r = 0; r < runs[c].size(); ++r) {
      const Row& x = runs[c][r];
      p50.push_back(x.latency_ms_p50);
      p99.push_back(x.latency_ms_p99);
      cpu.push_back(x.server_cpu_percent);
      added.push_back(x.latency_ms_p50 - runs[0][r].latency_ms_p50);
      added_cpu.push_back(x.server_cpu_percent - runs[0][r].server_cpu_percent);
      mb.push_back(x.recorded_mb_per_minute_per_camera);
      dropped += x.recorder_dropped;
      frames += x.recorded_frame_sets;
    }
    const bool rec = configs[c].tap.has_value();
    std::printf("%-42s %7.2fms %7.2fms %10.0f%% %10s %11s %14s %9s\n", configs[c].name.c_str(),
                median(p50), median(p99), median(cpu),
                rec ? fmt::format("{:+.2f}ms", median(added)).c_str() : "",
                rec ? fmt::format("{:+.0f}%", median(added_cpu)).c_str() : "",
                rec ? fmt::format("{:.1f}", median(mb)).c_str() : "",
                rec ? std::to_string(dropped).c_str() : "");
    nlohmann::json row = {{"configuration", configs[c].name}, {"latency_ms_p50", median(p50)},
                          {"latency_ms_p99", median(p99)},    {"server_cpu_percent", median(cpu)},
                          {"latency_ms_p50_runs", p50},       {"server_cpu_percent_runs", cpu}};
    if (rec) {
      row["added_latency_ms_p50"] = median(added);
      row["added_latency_ms_p50_runs"] = added;
      row["added_server_cpu_percent"] = median(added_cpu);
      row["recorded_mb_per_minute_per_camera"] = median(mb);
      row["recorded_frame_sets"] = frames;
      row["recorder_dropped"] = dropped;
    }
    rows.push_back(row);
  }
  fs::remove_all(dir);
  write_rows_json(a.json, "record", rows);
  return 0;
}

}  // namespace volcast
