// volcast: live RGB-D streaming for VR telepresence. One executable, one subcommand per task.
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <csignal>

#include "commands.hpp"
#include "volcast/codec/color_codec.hpp"
#include "volcast/codec/depth_codec.hpp"
#include "volcast/codec/registry.hpp"
#include "volcast/codec_video/video_codecs.hpp"
#include "volcast/core/error.hpp"

namespace {

void add_filter_flags(CLI::App* app, volcast::FilterFlags& f, bool with_background) {
  app->add_flag("--undistort", f.undistort,
                "Lens correction to an ideal pinhole (nearest neighbour)");
  app->add_option("--crop", f.crop, "Crop: nfov (540x476 of Azure Kinect NFOV) or x,y,w,h");
  if (!with_background) return;
  app->add_option("--near", f.near_mm, "Drop depth nearer than this (mm)");
  app->add_option("--far", f.far_mm, "Drop depth farther than this (mm)");
  app->add_option("--background", f.backgrounds,
                  "Learned background PNG per camera (repeat, camera order)");
  app->add_option("--background-margin", f.background_margin_mm,
                  "Keep only pixels this much nearer than the background (mm)")
      ->capture_default_str();
  app->add_flag("--flying-pixels", f.flying_pixels,
                "Remove flying pixels at depth discontinuities");
  app->add_option("--hole-fill", f.hole_fill,
                  "Hole filling: iterated median, N iterations (paper: 3)");
  app->add_flag("--kalman", f.kalman, "Per-pixel Kalman denoising with an innovation gate");
}

// --connect and --connect-file: one of them (connect_client_config reads them and says so if
// neither is given).
void add_connect_flags(CLI::App* c, std::string& connect, std::string& connect_file) {
  auto* link = c->add_option(
      "--connect", connect,
      "The join link the server printed (volcast://HOST:PORT/?token=...&fp=...), HOST:PORT with "
      "--token, or - to read the link from standard input (other users of this machine can read "
      "a command line, token included: prefer - or --connect-file)");
  link->excludes(c->add_option("--connect-file", connect_file,
                               "A file holding the join link (e.g. written by serve --link-file)"));
}

const std::string kTokenHelp =
    "Join token (32 hex digits) with --connect HOST:PORT (visible to other local users in the "
    "process list: prefer the link through --connect-file or --connect -)";

// The flags of every command that serves viewers (serve, replay, relay): the port, pacing,
// security, the browser page and the NATS account.
void add_server_flags(CLI::App* s, volcast::ServeArgs& serve, const std::string& kLowLatencyHelp) {
  s->add_option("--port", serve.port, "TCP port")->capture_default_str();
  s->add_option("--bind", serve.bind, "Address to listen on (0.0.0.0 for remote viewers)")
      ->capture_default_str();
  s->add_option("--key-frame-interval", serve.key_frame_interval,
                "Frames between temporal-codec key frames")
      ->capture_default_str();
  s->add_option("--max-viewers", serve.max_viewers, "Viewers served at once; more are rejected")
      ->capture_default_str();
  s->add_option(
       "--max-window", serve.max_window,
       "Frame sets in flight per viewer at most (pacing keeps ~2 bandwidth-delay products)")
      ->capture_default_str();
  s->add_option("--latency-budget", serve.latency_budget_ms,
                "Never send a frame set captured longer ago than this (ms)")
      ->capture_default_str();
  s->add_option("--min-key-interval", serve.min_key_interval_ms,
                "Key frames made on request (joins, skips) at most this often per tier (ms)")
      ->capture_default_str();
  s->add_option("--seconds", serve.seconds, "Stop after this many seconds (default: until Ctrl-C)");
  s->add_flag("--low-latency", serve.low_latency, kLowLatencyHelp);
  s->add_flag("--insecure", serve.insecure,
              "Plain TCP instead of TLS 1.3 (allowed only with a loopback --bind)");
  s->add_option("--cert", serve.cert,
                "TLS certificate PEM (default: a self-signed one made on first run in "
                "$XDG_CONFIG_HOME/volcast/server/)");
  s->add_option("--key", serve.key, "Private key PEM for --cert");
  s->add_option("--token-file", serve.token_file,
                "Join token file, 32 hex digits (default: a new random token per session)");
  s->add_option("--link-file", serve.link_file,
                "Also write the join link to this file, readable by you only (mode 0600): "
                "viewers on this machine join with --connect-file, the token off the command line");
  s->add_option("--link-host", serve.link_host,
                "Host name or address to print in the join link (default: --bind, or this "
                "host's first non-loopback address when bound to all)");
  s->add_option("--tiers", serve.tiers,
                "Offered tiers, comma-separated DEPTH/COLOR[/QUALITY], e.g. volcast/jpeg,trvl/none "
                "(default: any codec)")
      ->delimiter(',');
  s->add_option("--tier-cpu-budget", serve.tier_cpu_budget,
                "CPU cores the tiers' encoders may use together (each tier's cost estimated from "
                "its codecs, the site's pixels and frame rate); a viewer asking for a new tier "
                "past it is rejected (default 0: half this machine's cores, at least 1)")
      ->capture_default_str();
  s->add_option("--max-tiers-per-address", serve.max_tiers_per_address,
                "Tiers nobody else watches that one address's viewers may hold (together at most "
                "half the tier CPU budget)")
      ->capture_default_str();
  s->add_option("--handshake-timeout", serve.handshake_timeout_ms,
                "A viewer must finish TLS and its Hello within this many ms")
      ->capture_default_str();
  s->add_option("--max-pending", serve.max_pending,
                "Handshakes in progress at once (the oldest is dropped for a newcomer)")
      ->capture_default_str();
  s->add_option("--max-pending-per-address", serve.max_pending_per_address,
                "Handshakes in progress at once from one address")
      ->capture_default_str();
  s->add_flag("--web", serve.web,
              "Also serve the browser viewer (any headset's or laptop's browser, WebXR) on the "
              "same port, and print its https:// link");
  s->add_option("--web-root", serve.web_root,
                "The browser viewer's folder (default: the one built or installed with volcast)");
  s->add_option("--nats-user", serve.nats_user, "NATS user name (with --nats-password-file)");
  s->add_option("--nats-password-file", serve.nats_password_file,
                "A file whose first line is the NATS user's password");
  s->add_option("--nats-ca", serve.nats_ca,
                "TLS to the NATS cluster: the CA (PEM) its nodes' certificates must chain to");
  s->add_option("--nats-tls-name", serve.nats_tls_name,
                "With --nats-ca: the name every node's certificate must carry (else any "
                "certificate of the CA is taken)");
  s->add_option("--nats-cert", serve.nats_cert,
                "With --nats-ca: this process's client certificate (PEM), for nodes that verify "
                "clients");
  s->add_option("--nats-key", serve.nats_key, "The private key (PEM) of --nats-cert");
}

// The flags serve and replay share (replay has no cameras to filter: it takes them too and
// refuses them when given).
void add_serve_flags(CLI::App* s, volcast::ServeArgs& serve, const std::string& kLowLatencyHelp) {
  add_server_flags(s, serve, kLowLatencyHelp);
  s->add_option("--fps", serve.fps, "Frame sets per second (default: the recordings' own rate)");
  s->add_option("--intrinsics", serve.intrinsics,
                "fx,fy,cx,cy for image sequences without intrinsics.json");
  s->add_option("--max-read-failures", serve.max_read_failures,
                "A camera whose frames fail to read this many times in a row is marked failed "
                "(it repeats its last good frame; the others go on)")
      ->capture_default_str();
  s->add_option("--config", serve.config,
                "Site config JSON: {\"cameras\": [{\"source\", \"intrinsics\", \"filters\"}]}");
  add_filter_flags(s, serve.filters, true);
  s->add_option("--session", serve.sessions,
                "Virtual-OR sessions to open at start (repeat; participants may open more)")
      ->capture_default_str();
  s->add_option("--room-from-site", serve.room_from_site,
                "Where the site's cameras stand in the virtual OR: x,y,z (metres), yaw (degrees "
                "about +y); default: the site frame is the room frame");
  s->add_option("--site-name", serve.site_name, "The OR site's name in the sessions")
      ->capture_default_str();
  s->add_option("--presence-timeout", serve.presence_timeout_ms,
                "A participant silent this long (no pose, no heartbeat) is removed (ms)")
      ->capture_default_str();
  s->add_option("--case", serve.case_folder,
                "Patient case folder (organ meshes, label volumes, DICOM; see `volcast case`) "
                "shown in every session; changes to it are loaded and swapped for everyone");
  s->add_option("--case-max-triangles", serve.case_max_triangles,
                "Triangle budget per case part made from a label volume")
      ->check(CLI::Range(1000, 5000000))
      ->capture_default_str();
  s->add_option("--record", serve.record,
                "Also record one tier of the stream to this file (.vcr, append-only, survives "
                "a kill; see `volcast record`)");
  s->add_option("--record-tier", serve.record_tier,
                "The tier --record keeps: DEPTH/COLOR[/QUALITY]")
      ->capture_default_str();
  s->add_option("--nats", serve.nats,
                "Also publish the site's Welcome and --nats-tier's frame sets on this NATS "
                "cluster: URL[,URL...] (e.g. nats://127.0.0.1:4222)");
  s->add_option("--nats-tier", serve.nats_tiers,
                "A tier --nats publishes: DEPTH/COLOR[/QUALITY] (repeat for several)")
      ->capture_default_str();
  s->add_option("--nats-site", serve.nats_site,
                "The site's name in NATS subjects (volcast.SITE.tier...; A-Z a-z 0-9 _ -)")
      ->capture_default_str();
  s->add_option("--nats-cameras", serve.nats_cameras,
                "Add the cameras of capture nodes (serve --nats-site NODE --camera-only on other "
                "machines) to this site: NODE (repeat for several)");
  s->add_option("--nats-camera-tier", serve.nats_camera_tier,
                "The tier the capture nodes publish (their --nats-tier; lossless depth keeps it "
                "exact)")
      ->capture_default_str();
  s->add_option("--nats-state-replicas", serve.nats_state_replicas,
                "Keep the sessions' state (organ poses, owners, the monitor) in JetStream bucket "
                "volcast-SITE-sessions on this many nodes (0: not kept; the cluster needs "
                "JetStream); a restarted server puts it back")
      ->check(CLI::Range(0, 5))
      ->capture_default_str();
  s->add_flag("--camera-only", serve.camera_only,
              "A capture node: publish the cameras on --nats for a site server's --nats-cameras; "
              "no viewers (loopback only, no join link)");
  s->add_option("--from", serve.from_s, "A recording (.vcr) source: start this many seconds in")
      ->capture_default_str();
  s->add_option("--to", serve.to_s,
                "A recording (.vcr) source: end this many seconds in (default: its end)");
  s->add_flag("--no-loop", serve.no_loop,
              "A recording (.vcr) source: play it once, then stop (default: loop)");
}
}  // namespace

int main(int argc, char** argv) {
  using namespace volcast;
  std::signal(SIGINT, [](int) { g_interrupted = true; });
  std::signal(SIGTERM, [](int) { g_interrupted = true; });
  std::signal(SIGPIPE, SIG_IGN);
  // Logs go to stderr: stdout carries results (info's text and --json, the viewer's table).
  spdlog::set_default_logger(std::make_shared<spdlog::logger>(
      "", std::make_shared<spdlog::sinks::stderr_color_sink_mt>()));
  register_video_codecs();  // h264 and hevc join the codec table before anything looks one up

  CLI::App app{"volcast: stream RGB-D cameras to remote viewers as live point clouds"};
  app.require_subcommand(1);
  bool verbose = false;
  app.add_flag("-v,--verbose", verbose, "Log debug messages");

  const std::string kLowLatencyHelp =
      "Keep idle cores awake while streaming (Linux PM QoS: /dev/cpu_dma_latency = 0, needs "
      "root). Lower latency where waking a core is slow, e.g. virtual machines; costs power";

  ServeArgs serve;
  auto* s = app.add_subcommand("serve", "Stream one site (several cameras) to viewers over TCP");
  s->add_option(
       "--source", serve.sources,
       "Camera source: Azure Kinect .mkv, image-sequence folder (repeat per camera), or one "
       "Volcast recording .vcr")
      ->required();
  s->get_option("--source")->required(false);
  add_serve_flags(s, serve, kLowLatencyHelp);
  ServeArgs replay;
  auto* rp = app.add_subcommand(
      "replay", "Serve a recording (.vcr) to viewers, paced as recorded, looping (serve's flags)");
  rp->add_option("file", replay.sources, "Volcast recording (.vcr)")->required()->expected(1);
  add_serve_flags(rp, replay, kLowLatencyHelp);
  ServeArgs relay;
  auto* rl = app.add_subcommand(
      "relay",
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
  add_server_flags(rl, relay, kLowLatencyHelp);

  ViewArgs view;
  auto* v =
      app.add_subcommand("view", "Receive a site's stream and watch it in a window (or headset)");
  add_connect_flags(v, view.connect, view.connect_file);
  v->add_option("--token", view.token, kTokenHelp);
  v->add_option("--fingerprint", view.fingerprint,
                "Server certificate SHA-256 (64 hex) with --connect HOST:PORT (default: the one "
                "pinned on first use)");
  v->add_option("--known-servers", view.known_servers,
                "Pinned server certificates (default $XDG_CONFIG_HOME/volcast/known_servers)");
  v->add_flag("--insecure", view.insecure, "Plain TCP instead of TLS (loopback servers only)");
  v->add_option("--connect-timeout", view.connect_timeout_ms,
                "TCP connect and TLS handshake timeout (ms)")
      ->capture_default_str();
  v->add_option("--depth-codec", view.depth_codec, "Depth codec: " + depth_codec_help())
      ->capture_default_str();
  v->add_option("--color-codec", view.color_codec, "Color codec: " + color_codec_help())
      ->capture_default_str();
  v->add_option("--color-quality", view.color_quality,
                "Color quality 1..100 (JPEG quality, H.264 CRF from it; 0 = the codec default)")
      ->capture_default_str();
  v->add_flag("--no-render", view.no_render,
              "Receive and decode only (otherwise rendered in a window, a headset or offscreen)");
  v->add_flag("--headless", view.headless,
              "Render offscreen with EGL instead of opening a window (also the fallback when "
              "there is no display)");
  v->add_flag("--xr", view.xr,
              "Render to a VR headset through OpenXR (the window when no runtime is available)");
  v->add_option("--surface", view.surface, "Renderer: splats or mesh")
      ->check(CLI::IsMember({"splats", "splat", "mesh"}))
      ->capture_default_str();
  v->add_option("--splat-size", view.splat_size,
                "Splat size: fixed (--point-size pixels), footprint (the pixel's footprint x "
                "--splat-scale) or adaptive (footprint, enlarged where points are sparse)")
      ->check(CLI::IsMember({"fixed", "footprint", "adaptive"}))
      ->capture_default_str();
  v->add_option("--point-size", view.point_size, "Fixed splats: width in pixels")
      ->check(CLI::Range(1.0f, 64.0f))
      ->capture_default_str();
  v->add_option("--splat-scale", view.splat_scale, "Footprint splats: x the pixel's footprint")
      ->check(CLI::Range(0.1f, 10.0f))
      ->capture_default_str();
  v->add_option("--edge-ratio", view.edge_ratio,
                "Mesh: drop a triangle whose edge is longer than this x its nearer depth")
      ->check(CLI::Range(0.001f, 1.0f))
      ->capture_default_str();
  v->add_flag("--no-blend", view.no_blend,
              "Let the depth test pick between overlapping cameras instead of blending them");
  v->add_option("--site-config", view.site_config,
                "Site config JSON where the window's Save writes the cameras' world_from_camera "
                "(default volcast-site.json)");
  v->add_option("--frames", view.frames, "Stop after N frame sets");
  v->add_option("--seconds", view.seconds, "Stop after this many seconds");
  v->add_option("--screenshot", view.screenshot,
                "Headless: write the last render as PNG; window: where F12 / P write "
                "(default volcast-screenshot-N.png)");
  v->add_option("--save-frames", view.save_frames,
                "Write decoded depth (16-bit PNG) and color PNGs here");
  v->add_option("--stats-json", view.stats_json,
                "Write per-camera and per-stage latency statistics as JSON");
  v->add_option("--size", view.size, "Window or render size WIDTHxHEIGHT")->capture_default_str();
  v->add_option("--eye", view.eye, "Viewpoint x,y,z in metres (world frame)");
  v->add_option("--target", view.target, "Look-at point x,y,z in metres (world frame)");
  v->add_option("--keep-within", view.keep_within,
                "Avatar filter: draw only points within R metres of x,y,z (world frame): x,y,z,R");
  v->add_option("--hide-headset", view.hide_headset,
                "Avatar filter: hide the points of a headset at x,y,z (world frame, metres), "
                "facing -z turned by yaw degrees about +y: x,y,z[,yaw]");
  v->add_option("--handshake-timeout", view.handshake_timeout_ms,
                "Give up unless the server's Welcome arrives this soon after connecting (ms, "
                "0 = never)")
      ->capture_default_str();
  v->add_option("--receive-timeout", view.receive_timeout_ms,
                "End the session when no complete message arrives for this long (ms, 0 = never)")
      ->capture_default_str();
  v->add_flag("--low-latency", view.low_latency, kLowLatencyHelp);
  v->add_option("--join", view.join,
                "Join this virtual-OR session as a participant (made if there is none)");
  v->add_option("--name", view.name, "Your display name in the session (with --join)");
  v->add_option("--camera", view.camera,
                "Your own RGB-D camera (any source: .mkv, image folder, depth PNG): others see "
                "you as a live point-cloud avatar; without it, a mesh avatar");
  v->add_option("--camera-pose", view.camera_pose,
                "Your camera in your play area: x,y,z (metres), rx,ry,rz (degrees, R = Rz*Ry*Rx); "
                "default: facing you, 1.3 m high");
  v->add_option("--camera-intrinsics", view.camera_intrinsics,
                "fx,fy,cx,cy for a --camera source without intrinsics");
  v->add_option("--upload-codec", view.upload_codec,
                "Your camera's depth codec (lossless, not temporal: volcast, rvl, zstd, lz4, raw)")
      ->capture_default_str();
  v->add_option("--upload-color", view.upload_color, "Your camera's color codec: jpeg, raw, none")
      ->capture_default_str();
  v->add_option("--pose-script", view.pose_script,
                "Headless participant: JSON key poses and teleports (default: standing, swaying)");
  v->add_option("--pose-rate", view.pose_rate,
                "Poses published per second (at most 150: the sessions' limit per participant)")
      ->check(CLI::Range(1.0, 150.0))
      ->capture_default_str();
  v->add_option("--avatar-radius", view.avatar_radius,
                "Others' camera avatars: draw points within this many metres of their head")
      ->check(CLI::Range(0.05f, 5.0f))
      ->capture_default_str();
  v->add_flag("--no-room", view.no_room, "Participant: do not draw the room's furniture");
  v->footer(
      "Exit status: 0 when frame sets arrived and the session ended as asked (--frames, "
      "--seconds, Ctrl-C) or the server closed it; 1 when none arrived or it ended on an error "
      "(timeout, rejected, protocol error, connection lost), after printing the table and "
      "writing --stats-json with \"ended\" and \"error\".");

  DemoArgs demo;
  auto* d = app.add_subcommand("demo",
                               "Stream the shared real recordings on loopback, render and report");
  d->add_option("--seconds", demo.seconds, "How long the viewer receives")->capture_default_str();
  d->add_option("--out", demo.out, "Folder for stats.json and PNG renders")->capture_default_str();
  d->add_option("--data", demo.data, "Folder with the real recordings (default: ../shared/data)");
  d->add_option("--depth-codec", demo.depth_codec, "Depth codec: " + depth_codec_help())
      ->capture_default_str();
  d->add_option("--color-codec", demo.color_codec, "Color codec: " + color_codec_help())
      ->capture_default_str();
  d->add_flag("--no-session", demo.no_session,
              "Skip the virtual-OR session (the registered OR cameras, two scripted participants)");
  d->add_option("--session-seconds", demo.session_seconds, "How long the session part runs")
      ->capture_default_str();
  d->add_option("--cameras", demo.cameras,
                "2: the hands sequence and the Azure Kinect recording; 4: the four Azure Kinects")
      ->check(CLI::IsMember({2, 4}))
      ->capture_default_str();
  d->add_flag("--no-render", demo.no_render,
              "Render the PNGs only at the end, not while streaming (latency without a GPU)");
  d->add_flag("--low-latency", demo.low_latency, kLowLatencyHelp);

  FilterArgs filter;
  auto* f = app.add_subcommand(
      "filter",
      "Run the depth filter chain on a recording; write before/after PNGs and quality figures");
  f->add_option("--source", filter.source, "Azure Kinect .mkv or image-sequence folder")
      ->required();
  f->add_option("--out", filter.out, "Folder for PNGs and quality.json")->capture_default_str();
  f->add_option("--intrinsics", filter.intrinsics,
                "fx,fy,cx,cy for image sequences without intrinsics.json");
  f->add_option("--frames", filter.frames, "Frames to process (default: one pass, at most 300)");
  add_filter_flags(f, filter.filters, true);

  BackgroundArgs background;
  auto* b = app.add_subcommand(
      "background", "Learn a camera's background (per-pixel minimum depth) from the empty room");
  b->add_option("--source", background.source, "Recording of the empty room")->required();
  b->add_option("--out", background.out, "Model file to write (16-bit PNG)")->required();
  b->add_option("--intrinsics", background.intrinsics,
                "fx,fy,cx,cy for image sequences without intrinsics.json");
  b->add_option("--frames", background.frames, "Frames to learn from")->capture_default_str();
  add_filter_flags(b, background.filters, false);

  BenchArgs bench;
  auto* bn = app.add_subcommand(
      "bench", "Time the filter chain and the codecs on real recordings (one thread)");
  bn->add_option("--dataset", bench.datasets, "Extra recording or folder (repeat)");
  bn->add_option("--data", bench.data,
                 "Folder with the shared recordings (default ../shared/data)");
  bn->add_option("--json", bench.json, "Write the figures as JSON");
  bn->add_option("--repeats", bench.repeats, "Passes over each set (codecs: a tenth of it)")
      ->capture_default_str();
  bn->add_option("--frames", bench.frames,
                 "Frames of each sequence at most, for a quick look (default: all; the filter "
                 "chain takes 60)")
      ->check(CLI::NonNegativeNumber);
  bn->add_flag("--server", bench.server,
               "Server benchmark instead: 2 and 4 real cameras, 1/4/8/16 receive-only viewers");
  bn->add_option("--server-seconds", bench.server_seconds,
                 "With --server: seconds measured per configuration")
      ->capture_default_str();
  bn->add_option("--server-repeats", bench.server_repeats,
                 "With --server: TCP/TLS pairs run per configuration, interleaved; medians shown")
      ->capture_default_str();
  bn->add_option("--viewers", bench.viewers,
                 "With --server or --nats: viewer counts to run (repeat)");
  bn->add_flag("--nats", bench.nats,
               "Benchmark the stream through a 3-node NATS cluster (nats-server, started here) "
               "and relays to --viewers viewers (default 50), against the site's own server "
               "(--server-seconds each)");
  bn->add_flag("--nats-tls", bench.nats_tls,
               "With --nats: TLS on the links to the cluster's nodes (self-signed, verified)");
  bn->add_option("--relays", bench.relays, "With --nats: relays the viewers are spread over")
      ->capture_default_str();
  bn->add_flag("--session", bench.session,
               "Session benchmark instead: pose round trip, pose rates, camera avatars, server CPU "
               "per participant (--server-seconds each)");
  bn->add_flag("--low-latency", bench.low_latency, "With --session: " + kLowLatencyHelp);
  bn->add_flag("--record", bench.record,
               "Recording benchmark instead: latency and CPU a server-side recorder adds to a "
               "live viewer, MB per minute per camera (--server-seconds, --server-repeats)");
  bn->add_flag("--render", bench.render,
               "Render benchmark instead: splats and mesh, 1/2/4 real cameras, mono and stereo");
  bn->add_option("--render-seconds", bench.render_seconds,
                 "With --render: seconds drawn per configuration (at least 3 frames)")
      ->capture_default_str();

  CalibrateArgs calibrate;
  auto* c = app.add_subcommand(
      "calibrate",
      "Place the cameras to each other and to the room from depth alone (lattice target where "
      "seen, else ICP over their overlap); print residuals, write a site config");
  c->add_option("--source", calibrate.sources,
                "Camera: Azure Kinect .mkv, image-sequence folder, or depth.<serial>-*.png; a "
                "folder of depth.<serial>-*.png files is one camera per serial (repeat)")
      ->required();
  c->add_option("--out", calibrate.out, "Site config to write (serve --config, view --site-config)")
      ->capture_default_str();
  c->add_option("--preview", calibrate.preview,
                "PNG of the registered cameras from above and from the side, one tint each");
  c->add_option("--intrinsics-from", calibrate.intrinsics_from,
                "Intrinsics for a camera folder's PNGs: an Azure Kinect .mkv (factory "
                "calibration) or image-sequence folder (default: the shared Azure Kinect "
                "recording's, as NOMINAL intrinsics)");
  c->add_option("--start", calibrate.start,
                "Site config with rough poses (within ~20 cm / 10 deg, e.g. saved from the "
                "viewer's sliders): ICP starts there instead of searching features");
  c->add_option("--reference", calibrate.reference,
                "Camera whose frame is the site's before the floor is found")
      ->capture_default_str();
  c->add_flag("--reference-target", calibrate.reference_target,
              "The target's first placement defines the world instead of a camera");
  c->add_option("--frames", calibrate.frames, "Frame sets to scan for the target")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  c->add_flag("--no-target", calibrate.no_target, "Do not look for the lattice target");
  c->add_flag("--refine", calibrate.refine,
              "Also refine target-placed cameras by ICP over the overlap");
  c->add_flag("--no-floor", calibrate.no_floor,
              "Keep the reference camera's frame; do not put the floor at y = 0");

  InfoArgs info;
  auto* i = app.add_subcommand(
      "info",
      "Describe a recording: streams, frames, derived intrinsics; reads every frame and lists "
      "those that cannot be read (exit code 0 whenever the source opens)");
  i->add_option("file", info.file,
                "Azure Kinect .mkv, image-sequence folder, or Volcast recording .vcr")
      ->required();
  i->add_flag("--json", info.json, "Print JSON");

  RecordArgs record;
  auto* rc = app.add_subcommand(
      "record",
      "Record a server's stream, one tier as sent, to an append-only .vcr that survives a kill "
      "(replay it with `volcast replay`, export it with `volcast export`)");
  add_connect_flags(rc, record.connect, record.connect_file);
  rc->add_option("--token", record.token, kTokenHelp);
  rc->add_option("--fingerprint", record.fingerprint,
                 "With HOST:PORT: the server certificate's SHA-256 (64 hex digits)");
  rc->add_option("--known-servers", record.known_servers,
                 "Pinned server certificates (default: $XDG_CONFIG_HOME/volcast/known_servers)");
  rc->add_flag("--insecure", record.insecure, "Plain TCP (loopback only)");
  rc->add_option("--out", record.out, "The recording to write (.vcr)")->required();
  rc->add_option("--tier", record.tier, "The tier to record: DEPTH/COLOR[/QUALITY]")
      ->capture_default_str();
  rc->add_option("--seconds", record.seconds, "Stop after this many seconds (default: Ctrl-C)");
  rc->add_flag("--overwrite", record.overwrite, "Replace --out if it exists");
  rc->add_option("--sync-interval", record.sync_interval_ms,
                 "Flush to disk at least this often (ms): what a power cut can lose")
      ->capture_default_str();

  ExportArgs export_args;
  auto* ex = app.add_subcommand(
      "export",
      "Export a recording (.vcr): binary PLY point clouds, 16-bit depth + color PNGs, or Azure "
      "Kinect-style Matroska");
  ex->add_option("file", export_args.file, "Volcast recording (.vcr)")->required();
  ex->add_option("--ply", export_args.ply,
                 "Folder for one binary PLY per camera and frame set (world frame, metres, "
                 "with color)");
  ex->add_option("--png", export_args.png,
                 "Folder for depth (16-bit PNG, mm) and color (PNG) per camera and frame set");
  ex->add_option("--mkv", export_args.mkv,
                 "Azure Kinect-style Matroska: DEPTH track (b16g), calibration.json, color "
                 "registered to depth as a COLOR_ON_DEPTH track; one file per camera "
                 "(FILE-camera-C.mkv) for several; `volcast info` reads it back");
  ex->add_option("--from", export_args.from_s, "Start this many seconds in")->capture_default_str();
  ex->add_option("--to", export_args.to_s, "End this many seconds in (default: the end)");

  CaseArgs case_args;
  auto* ca = app.add_subcommand(
      "case",
      "Load a patient case (organ meshes, label volumes made into meshes, a DICOM series) and "
      "print its parts and series; the folder serve --case shows in the virtual OR");
  ca->add_option("folder", case_args.folder, "Case folder (case.json optional)")->required();
  ca->add_flag("--json", case_args.json, "Print JSON");
  ca->add_option("--render", case_args.render, "PNG of the case: front and top views");
  ca->add_option("--max-triangles", case_args.max_triangles,
                 "Triangle budget per part made from a label volume")
      ->check(CLI::Range(1000, 5000000))
      ->capture_default_str();

  CLI11_PARSE(app, argc, argv);
  if (verbose) spdlog::set_level(spdlog::level::debug);
  try {
    if (*s) return run_serve(serve);
    if (*v) return run_view(view);
    if (*d) return run_demo(demo);
    if (*i) return run_info(info);
    if (*rp) return run_serve(replay);
    if (*rl) return run_relay(relay);
    if (*rc) return run_record(record);
    if (*ex) return run_export(export_args);
    if (*c) return run_calibrate(calibrate);
    if (*ca) return run_case(case_args);
    if (*f) return run_filter(filter);
    if (*b) return run_background(background);
    if (*bn) {
      if (int(bench.server) + int(bench.render) + int(bench.session) + int(bench.record) +
              int(bench.nats) >
          1)
        throw Error("bench: --server, --render, --session, --record and --nats are separate runs");
      return bench.nats      ? run_nats_bench(bench)
             : bench.server  ? run_server_bench(bench)
             : bench.render  ? run_render_bench(bench)
             : bench.session ? run_session_bench(bench)
             : bench.record  ? run_record_bench(bench)
                             : run_bench(bench);
    }
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 1;
}
