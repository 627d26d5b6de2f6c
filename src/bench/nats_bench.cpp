// volcast bench --nats: a site's stream through a NATS cluster and relays to many receive-only
// viewers, against the same viewers on the site's own server (issue 17's goals).
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "volcast/bench/bench.hpp"
#include "volcast/capture/real_sites.hpp"
#include "volcast/cluster/local_cluster.hpp"
#include "volcast/cluster/relay.hpp"
#include "volcast/cluster/tier_publisher.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/private_file.hpp"
#include "volcast/net/stream/client.hpp"
#include "volcast/net/transport/tls.hpp"
#include "volcast/pipeline/sender.hpp"
#include "volcast/pipeline/stage_stats.hpp"

namespace volcast {
namespace {
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// One receive-only viewer (reads and acknowledges, decodes nothing: the figures are the
// serving side's) on its own thread, counting while `measuring`.
struct Viewer {
  std::string link;
  std::atomic<bool> measuring{false}, watching_gaps{false}, done{false};
  std::mutex mutex;
  uint64_t frames = 0;
  std::vector<double> latency_ms;  // capture at the site -> message read here
  double max_gap_ms = 0;           // while watching_gaps: the longest wait between frame sets
  std::string error;
  std::thread thread;

  void start() {
    thread = std::thread([this] {
      try {
        ClientConfig c = client_config_from_link(link);
        c.decode = false;
        c.receive_timeout_ms = 20000;
        Client client(c);
        ReceivedFrameSet rx;
        int64_t last_us = 0;
        while (!done && client.receive(rx)) {
          std::lock_guard lock(mutex);
          if (watching_gaps && last_us)
            max_gap_ms =
                std::max(max_gap_ms, static_cast<double>(rx.times.received_us - last_us) / 1e3);
          last_us = rx.times.received_us;
          if (!measuring) continue;
          ++frames;
          latency_ms.push_back(static_cast<double>(rx.times.received_us - rx.times.capture_us) /
                               1e3);
        }
        client.close();
      } catch (const std::exception& e) {
        std::lock_guard lock(mutex);
        if (!done) error = e.what();
      }
    });
  }
  void stop() {
    done = true;
    if (thread.joinable()) thread.join();
  }
};

struct Figures {
  double fps_min = 0, p50 = 0, p99 = 0;
};

// Measures `viewers` for `seconds` after a warm-up. Throws Error if a viewer failed.
Figures measure(std::vector<std::unique_ptr<Viewer>>& viewers, double seconds) {
  std::this_thread::sleep_for(std::chrono::milliseconds(2000));  // joins, key frames, warm-up
  for (auto& v : viewers) v->measuring = true;
  const auto t0 = Clock::now();
  std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
  for (auto& v : viewers) v->measuring = false;
  const double wall = std::chrono::duration<double>(Clock::now() - t0).count();
  Figures f;
  f.fps_min = 1e9;
  std::vector<double> all;
  for (auto& v : viewers) {
    std::lock_guard lock(v->mutex);
    if (!v->error.empty()) throw Error("bench viewer failed: " + v->error);
    f.fps_min = std::min(f.fps_min, static_cast<double>(v->frames) / wall);
    all.insert(all.end(), v->latency_ms.begin(), v->latency_ms.end());
  }
  f.p50 = percentile(all, 0.5);
  f.p99 = percentile(all, 0.99);
  return f;
}

std::vector<std::unique_ptr<Viewer>> start_viewers(int n, const std::vector<std::string>& links) {
  std::vector<std::unique_ptr<Viewer>> viewers;
  for (int i = 0; i < n; ++i) {
    auto v = std::make_unique<Viewer>();
    v->link = links[static_cast<size_t>(i) % links.size()];
    v->start();
    viewers.push_back(std::move(v));
  }
  return viewers;
}

ServerConfig bench_server(int viewers) {
  ServerConfig c;
  c.port = 0;
  c.max_viewers = viewers + 4;
  c.max_pending = std::max(64, viewers + 4);
  c.max_pending_per_address = std::max(64, viewers + 4);  // every viewer comes from 127.0.0.1
  return c;
}

}  // namespace

int run_nats_bench(const BenchArgs& a) {
  const auto data = find_data(a.data);
  if (!data) throw Error("bench --nats: the real recordings were not found (--data DIR)");
  const std::vector<int> counts = a.viewers.empty() ? std::vector<int>{50} : a.viewers;
  for (int v : counts)
    if (v < 1 || v > 200) throw Error("--viewers must be 1..200 with --nats");
  if (a.relays < 1 || a.relays > 8) throw Error("--relays must be 1..8");
  spdlog::set_level(spdlog::level::warn);
  const fs::path dir = fs::temp_directory_path() / fmt::format("volcast-nats-bench-{}", getpid());
  std::printf(
      "the real two-camera site at 30 fps, tier volcast/jpeg, TLS, receive-only viewers; "
      "%d relays on a 3-node nats-server cluster (loopback, %s links), %.0f s per figure\n",
      a.relays, a.nats_tls ? "TLS" : "plain", a.server_seconds);
  std::printf("%8s %7s | %13s %13s | %10s %10s %10s | %12s %6s\n", "viewers", "relays",
              "direct fps", "direct p50", "relay fps", "relay p50", "relay p99", "node kill gap",
              "lost");
  nlohmann::json rows = nlohmann::json::array();
  for (int n : counts) {
    // Direct: every viewer on the site's own server.
    Figures direct;
    {
      SitePlayer site(two_camera_site(*data), 30);
      Server server(site.cameras(), bench_server(n));
      site.start(server);
      auto viewers = start_viewers(n, {server.join_link("127.0.0.1")});
      direct = measure(viewers, a.server_seconds);
      for (auto& v : viewers) v->done = true;
      site.stop();
      server.stop();
      for (auto& v : viewers) v->stop();
    }
    // Relayed: the site publishes on node 0; relay k takes the stream from node k + 1.
    cluster::NatsOptions tls;  // with --nats-tls: the node certificate, checked by CA and name
    std::string tls_config;
    if (a.nats_tls) {
      fs::create_directories(dir);
      const TlsIdentity node = make_self_signed_identity("localhost");
      std::ofstream(dir / "node.pem") << node.certificate_pem;
      write_private_file(dir / "node.key", node.private_key_pem);
      tls.ca_file = (dir / "node.pem").string();
      tls.tls_name = "localhost";
      tls_config = fmt::format("tls {{\n  cert_file: \"{}\"\n  key_file: \"{}\"\n}}\n",
                               (dir / "node.pem").string(), (dir / "node.key").string());
    }
    cluster::LocalNatsCluster nats(dir, 3, tls_config, tls);
    SitePlayer site(two_camera_site(*data), 30);
    Server server(site.cameras(), bench_server(4));
    cluster::NatsOptions site_link = tls;
    site_link.urls = nats.urls(0);
    site_link.in_order = true;
    cluster::NatsConnection site_nats(site_link);
    cluster::TierPublisher publisher(site_nats, "bench", {site.cameras(), wall_clock_us()});
    publisher.publish_tier(server, Tier{"volcast", "jpeg", 0});
    site.start(server);
    std::vector<std::unique_ptr<cluster::NatsConnection>> links;
    std::vector<std::unique_ptr<cluster::Relay>> relays;
    std::vector<std::string> relay_links;
    for (int k = 0; k < a.relays; ++k) {
      cluster::NatsOptions o = tls;
      o.urls = nats.urls((k + 1) % nats.nodes());
      o.in_order = true;
      links.push_back(std::make_unique<cluster::NatsConnection>(o));
      cluster::RelayOptions r;
      r.site = "bench";
      r.server = bench_server(n);
      relays.push_back(std::make_unique<cluster::Relay>(*links.back(), r));
      relay_links.push_back(relays.back()->server().join_link("127.0.0.1"));
    }
    auto viewers = start_viewers(n, relay_links);
    const Figures relayed = measure(viewers, a.server_seconds);
    // A node goes down: relay 0's. Its viewers wait while libnats moves it to another node.
    for (auto& v : viewers) v->watching_gaps = true;
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
    nats.kill(1 % nats.nodes());
    std::this_thread::sleep_for(std::chrono::seconds(4));
    double gap_ms = 0;
    int lost = 0;
    for (auto& v : viewers) {
      std::lock_guard lock(v->mutex);
      gap_ms = std::max(gap_ms, v->max_gap_ms);
      lost += !v->error.empty();
    }
    for (auto& v : viewers) v->done = true;
    site.stop();
    for (auto& r : relays) r->server().stop();
    for (auto& v : viewers) v->stop();
    relays.clear();
    server.stop();
    std::printf("%8d %7d | %13.1f %10.1f ms | %10.1f %7.1f ms %7.1f ms | %9.0f ms %6d\n", n,
                a.relays, direct.fps_min, direct.p50, relayed.fps_min, relayed.p50, relayed.p99,
                gap_ms, lost);
    std::fflush(stdout);
    rows.push_back({{"viewers", n},
                    {"relays", a.relays},
                    {"nats_nodes", nats.nodes()},
                    {"nats_tls", a.nats_tls},
                    {"fps_min", relayed.fps_min},
                    {"latency_ms_p50", relayed.p50},
                    {"latency_ms_p99", relayed.p99},
                    {"direct_fps_min", direct.fps_min},
                    {"direct_latency_ms_p50", direct.p50},
                    {"direct_latency_ms_p99", direct.p99},
                    {"node_kill_max_gap_ms", gap_ms},
                    {"node_kill_viewers_lost", lost}});
  }
  fs::remove_all(dir);
  if (!a.json.empty()) {
    nlohmann::json j;
    j["nats"] = rows;
    const fs::path p = a.json;
    if (p.has_parent_path()) fs::create_directories(p.parent_path());
    std::ofstream(p) << j.dump(2) << "\n";
    std::printf("wrote %s\n", p.c_str());
  }
  return 0;
}

}  // namespace volcast
