// volcast serve and replay: one site's cameras (or a recording) to viewers, with the virtual OR's
// sessions, the case, a recorder and the NATS cluster as the flags ask: the flags parsed into a
// SiteServer (volcast/site/site_server.hpp), which runs until Ctrl-C, --seconds or a replay's end.
#include <spdlog/spdlog.h>

#include <Eigen/Geometry>
#include <chrono>
#include <filesystem>
#include <thread>

#include "cli.hpp"
#include "commands.hpp"
#include "options.hpp"
#include "volcast/codec/tier.hpp"
#include "volcast/core/error.hpp"
#include "volcast/site/site_server.hpp"

namespace volcast {
namespace {

// Whether serve's sources are one Volcast recording (replayed as recorded). Throws Error when a
// recording is mixed with cameras or given filters.
bool replaying(const ServeArgs& a) {
  bool any = false;
  for (const auto& s : a.sources) any = any || std::filesystem::path(s).extension() == ".vcr";
  if (!any) return false;
  if (a.sources.size() != 1 || !a.config.empty())
    throw Error(
        "serve: a recording (.vcr) is a whole site: give it alone, without other "
        "--source or --config");
  if (a.filters.to_config(0).any())
    throw Error("serve: a recording (.vcr) is replayed as recorded: drop the filter flags");
  return true;
}

// The site server's settings from serve's (and replay's) flags.
SiteServerOptions site_options(const ServeArgs& a) {
  SiteServerOptions o;
  if (replaying(a)) {
    o.replay_path = a.sources[0];
    o.replay = ReplayOptions{a.from_s, a.to_s, !a.no_loop};
  } else {
    o.sources = a.sources;
  }
  o.site_config = a.config;
  if (!a.intrinsics.empty()) o.intrinsics = parse_pinhole(a.intrinsics);
  o.filters = [flags = a.filters](size_t camera) { return flags.to_config(camera); };
  o.fps = a.fps;
  o.max_read_failures = a.max_read_failures;
  if (!a.nats.empty()) o.nats = nats_options(a, "volcast serve " + a.nats_site);
  o.nats_site = a.nats_site;
  o.nats_cameras = a.nats_cameras;
  o.nats_camera_tier =
      parse_tier(a.nats_camera_tier, "--nats-camera-tier", TierRate::kEveryFrameSet);
  for (const std::string& t : a.nats_tiers)
    o.nats_tiers.push_back(parse_tier(t, "--nats-tier", TierRate::kEveryFrameSet));
  o.nats_state_replicas = a.nats_state_replicas;
  o.camera_only = a.camera_only;
  o.hub.site_name = a.site_name;
  o.hub.presence_timeout_ms = a.presence_timeout_ms;
  if (!a.room_from_site.empty()) {
    const auto r = parse_numbers(a.room_from_site, 4, "--room-from-site");
    o.hub.site_translation = Eigen::Vector3d(r[0], r[1], r[2]).cast<float>();
    o.hub.site_yaw = static_cast<float>(r[3] * M_PI / 180);
  }
  o.sessions = a.sessions;
  o.mic = a.mic;
  o.speaker = a.speaker;
  o.echo_cancellation = !a.no_echo_cancellation;
  o.case_folder = a.case_folder;
  o.case_max_triangles = a.case_max_triangles;
  o.server = server_config(a);
  o.record_path = a.record;
  o.record_tier = parse_tier(a.record_tier, "--record-tier", TierRate::kEveryFrameSet);
  return o;
}

// Prints where to join: the join link (and --link-file), the browser link.
void print_links(const ServeArgs& a, SiteServer& site) {
  Server& server = site.server();
  spdlog::info("serving {} camera(s) at {:.1f} fps on {}:{} ({}; Ctrl-C stops)",
               site.cameras().size(), site.fps(), a.bind, server.port(),
               a.insecure ? "plain TCP, loopback only" : "TLS 1.3");
  if (!a.camera_only)
    spdlog::info("tiers may use {:.1f} CPU cores to encode (--tier-cpu-budget)",
                 server.tier_cpu_budget());
  if (a.camera_only)
    std::printf(
        "capture node: %zu camera(s) published on NATS as site '%s' (a site server adds "
        "them with --nats-cameras %s)\n",
        site.cameras().size(), a.nats_site.c_str(), a.nats_site.c_str());
  else if (!a.insecure)
    spdlog::info("certificate SHA-256 fingerprint: {}", server.fingerprint());
  if (!a.camera_only) {
    std::printf("join link (give it only to the viewers of this session):\n  %s\n",
                server.join_link(link_host(a)).c_str());
    write_link_file(a, server.join_link(link_host(a)));
  }
  if (a.web || !a.web_root.empty())
    std::printf("browser link (any headset's or laptop's browser; accept the certificate):\n  %s\n",
                server.web_link(link_host(a)).c_str());
  std::fflush(stdout);
}

}  // namespace

int run_serve(const ServeArgs& a) {
  const auto low_latency = hold_low_latency(a.low_latency);  // the whole run, shutdown included
  SiteServer site(site_options(a));
  site.start();
  print_links(a, site);
  const auto start = std::chrono::steady_clock::now();
  auto last_report = start;
  while (!g_interrupted) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    const auto now = std::chrono::steady_clock::now();
    if (a.seconds > 0 && now - start > std::chrono::duration<double>(a.seconds)) break;
    if (site.finished()) {
      spdlog::info("the recording has played to its end (--no-loop)");
      break;
    }
    if (now - last_report > std::chrono::seconds(5)) {
      last_report = now;
      spdlog::info("{}", site.progress());
    }
  }
  site.stop();
  return 0;
}

void register_serve(CLI::App& app, Commands& commands) {
  auto [s, serve] = add_command<ServeArgs>(app, commands, run_serve, "serve",
                                           "Stream one site (several cameras) to viewers over TCP");
  s->add_option(
       "--source", serve.sources,
       "Camera source: Azure Kinect .mkv, image-sequence folder (repeat per camera), or one "
       "Volcast recording .vcr")
      ->required();
  s->get_option("--source")->required(false);
  add_serve_flags(s, serve);
}

void register_replay(CLI::App& app, Commands& commands) {
  auto [rp, replay] = add_command<ServeArgs>(
      app, commands, run_serve, "replay",
      "Serve a recording (.vcr) to viewers, paced as recorded, looping (serve's flags)");
  rp->add_option("file", replay.sources, "Volcast recording (.vcr)")->required()->expected(1);
  add_serve_flags(rp, replay);
}

}  // namespace volcast
