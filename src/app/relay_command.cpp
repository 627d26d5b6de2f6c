// volcast relay: a site's stream taken from a NATS cluster and served to viewers (issue 17).
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <cstdio>
#include <thread>

#include "cli.hpp"
#include "commands.hpp"
#include "volcast/cluster/relay.hpp"
#include "volcast/codec/tier.hpp"
#include "volcast/core/error.hpp"

namespace volcast {

int run_relay(const ServeArgs& a) {
  const auto low_latency = hold_low_latency(a.low_latency);
  cluster::RelayOptions o;
  o.site = a.nats_site;
  o.tier = parse_tier(a.relay_tier, "--tier", TierRate::kEveryFrameSet);
  o.welcome_timeout_ms = a.welcome_timeout_ms;
  o.relay_name = a.relay_name;
  o.session = !a.relay_no_session;
  o.server = server_config(a);
  cluster::NatsConnection nats(nats_options(a, "volcast relay " + a.nats_site));
  spdlog::info("relay: waiting for site '{}' on {}", a.nats_site, a.nats);
  cluster::Relay relay(nats, o);
  Server& server = relay.server();
  for (size_t i = 0; i < relay.cameras().size(); ++i) {
    const auto& k = relay.cameras()[i].calibration.depth;
    spdlog::info("camera {}: {} ({}x{})", i, relay.cameras()[i].description, k.width, k.height);
  }
  spdlog::info("relaying on {}:{} ({}; Ctrl-C stops); viewers of {} get the site's own bytes",
               a.bind, server.port(), a.insecure ? "plain TCP, loopback only" : "TLS 1.3",
               a.relay_tier);
  if (!a.insecure) spdlog::info("certificate SHA-256 fingerprint: {}", server.fingerprint());
  if (relay.session())
    spdlog::info("participants join site '{}''s sessions through this relay (as {})", a.nats_site,
                 relay.session()->relay());
  std::printf("join link (give it only to the viewers of this session):\n  %s\n",
              server.join_link(link_host(a)).c_str());
  write_link_file(a, server.join_link(link_host(a)));
  if (!o.server.web_root.empty())
    std::printf("browser link (any headset's or laptop's browser; accept the certificate):\n  %s\n",
                server.web_link(link_host(a)).c_str());
  std::fflush(stdout);
  const auto start = std::chrono::steady_clock::now();
  auto last_report = start;
  uint64_t last_frames = 0;
  while (!g_interrupted) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    const auto now = std::chrono::steady_clock::now();
    if (a.seconds > 0 && now - start > std::chrono::duration<double>(a.seconds)) break;
    if (now - last_report < std::chrono::seconds(5)) continue;
    const double dt = std::chrono::duration<double>(now - last_report).count();
    last_report = now;
    int connected = 0;
    for (const auto& v : server.viewers()) connected += v.connected;
    const cluster::RelayStats st = relay.stats();
    spdlog::info(
        "{} frame sets relayed ({:.1f} fps), {} viewer(s) connected{}{}", st.frame_sets,
        static_cast<double>(st.frame_sets - last_frames) / dt, connected,
        st.undecodable ? fmt::format("; {} dropped ({})", st.undecodable, st.last_error) : "",
        st.nats_dropped ? fmt::format("; NATS dropped {} (too slow)", st.nats_dropped) : "");
    last_frames = st.frame_sets;
  }
  const cluster::RelayStats st = relay.stats();
  std::printf(
      "relayed %llu frame sets of site '%s' (%llu chunks malformed, %llu frame sets incomplete, "
      "%llu dropped)\n",
      static_cast<unsigned long long>(st.frame_sets), a.nats_site.c_str(),
      static_cast<unsigned long long>(st.chunks.malformed),
      static_cast<unsigned long long>(st.chunks.incomplete),
      static_cast<unsigned long long>(st.undecodable));
  for (const auto& v : server.viewers())
    spdlog::info(
        "viewer {} ({}): {} frame sets sent, {} skipped ({} over the latency budget), {:.1f} MB",
        v.peer, to_string(v.tier), v.frames_sent, v.frames_dropped, v.frames_stale,
        static_cast<double>(v.bytes_sent) / 1e6);
  return 0;
}

void register_relay(CLI::App& app, Commands& commands) {
  auto [rl, relay] = add_command<ServeArgs>(
      app, commands, run_relay, "relay",
      "Serve a site's stream taken from a NATS cluster (serve --nats publishes it): as many "
      "relays as you like, on any machines; viewers need only a relay's link");
  rl->add_option("--nats", relay.nats, "The NATS cluster: URL[,URL...] (e.g. nats://HOST:4222)")
      ->required();
  rl->add_option("--site", relay.nats_site, "The site to relay (serve's --nats-site)")
      ->capture_default_str();
  rl->add_option("--tier", relay.relay_tier,
                 "The published tier to take (one of serve's --nats-tier): DEPTH/COLOR[/QUALITY]; "
                 "its viewers get the site's bytes, other tiers are encoded here")
      ->capture_default_str();
  rl->add_option("--relay-name", relay.relay_name,
                 "This relay's name in the session's NATS subjects (volcast.SITE.session.up.NAME; "
                 "unique among the site's relays; default: a random one), for per-relay "
                 "permissions");
  rl->add_flag("--no-session", relay.relay_no_session,
               "Stream only: viewers cannot join the site's sessions through this relay");
  rl->add_option("--welcome-timeout", relay.welcome_timeout_ms,
                 "Give up unless the site's Welcome arrives this soon (ms)")
      ->capture_default_str();
  add_server_flags(rl, relay);
}

}  // namespace volcast
