// The flags several subcommands share: filters, where to connect, serving viewers.
#include "cli.hpp"
#include "commands.hpp"

namespace volcast {

const std::string kLowLatencyHelp =
    "Keep idle cores awake while streaming (Linux PM QoS: /dev/cpu_dma_latency = 0, needs "
    "root). Lower latency where waking a core is slow, e.g. virtual machines; costs power";

const std::string kTokenHelp =
    "Join token (32 hex digits) with --connect HOST:PORT (visible to other local users in the "
    "process list: prefer the link through --connect-file or --connect -)";

void add_filter_flags(CLI::App* app, FilterFlags& f, bool with_background) {
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

void add_connect_flags(CLI::App* c, std::string& connect, std::string& connect_file) {
  auto* link = c->add_option(
      "--connect", connect,
      "The join link the server printed (volcast://HOST:PORT/?token=...&fp=...), HOST:PORT with "
      "--token, or - to read the link from standard input (other users of this machine can read "
      "a command line, token included: prefer - or --connect-file)");
  link->excludes(c->add_option("--connect-file", connect_file,
                               "A file holding the join link (e.g. written by serve --link-file)"));
}

void add_server_flags(CLI::App* s, ServeArgs& serve) {
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
  s->add_option("--ladder", serve.ladder,
                "Tier ladder for adaptive viewers (view without --depth-codec), best first, "
                "comma-separated DEPTH/COLOR[/QUALITY][@N] (@N: every Nth frame set), or none")
      ->delimiter(',')
      ->capture_default_str();
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

void add_serve_flags(CLI::App* s, ServeArgs& serve) {
  add_server_flags(s, serve);
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
  s->add_option("--mic", serve.mic,
                "The OR's microphone: a sound device (\"default\" or part of its name) or a .wav "
                "file; it speaks in every session as the OR site");
  s->add_option(
      "--speaker", serve.speaker,
      "The OR's loudspeaker: a sound device or a .wav file; the remote voices play on it, "
      "mixed");
  s->add_flag("--no-echo-cancellation", serve.no_echo_cancellation,
              "Do not cancel the loudspeaker's echo in the microphone (headphones in the OR)");
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

}  // namespace volcast
