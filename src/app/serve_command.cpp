#include <arpa/inet.h>
#include <fmt/format.h>
#include <ifaddrs.h>
#include <spdlog/spdlog.h>
#include <sys/stat.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <fstream>
#include <iostream>
#include <sstream>
#include <thread>

#include "case_watch.hpp"
#include "commands.hpp"
#include "options.hpp"
#include "volcast/cluster/remote_site.hpp"
#include "volcast/cluster/session_link.hpp"
#include "volcast/cluster/session_state.hpp"
#include "volcast/cluster/tier_publisher.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/private_file.hpp"
#include "volcast/io/site_config.hpp"
#include "volcast/net/protocol/join.hpp"
#include "volcast/net/transport/connection.hpp"
#include "volcast/net/transport/tls.hpp"
#include "volcast/pipeline/receiver.hpp"
#include "volcast/pipeline/replay.hpp"
#include "volcast/pipeline/sender.hpp"
#include "volcast/pipeline/session_client.hpp"
#include "volcast/pipeline/session_scene.hpp"
#include "volcast/record/recorder.hpp"
#include "volcast/session/hub.hpp"
#include "volcast/viewer/desktop.hpp"
#include "volcast/viewer/xr.hpp"

namespace volcast {

std::atomic<bool> g_interrupted{false};

FilterConfig FilterFlags::to_config(size_t index) const {
  FilterConfig c;
  c.undistort = undistort;
  if (!crop.empty()) c.crop = parse_crop(crop);
  if (near_mm < 0 || near_mm > 65535 || far_mm < 0 || far_mm > 65535)
    throw Error("--near/--far must be 0..65535 mm");
  c.near_mm = static_cast<uint16_t>(near_mm);
  c.far_mm = static_cast<uint16_t>(far_mm);
  if (index < backgrounds.size()) c.background_file = backgrounds[index];
  c.background_margin_mm = static_cast<uint16_t>(std::clamp(background_margin_mm, 0, 65535));
  if (flying_pixels) c.flying_pixels = FlyingPixelFilter{};
  if (hole_fill > 0) {
    c.hole_filling = HoleFiller{};
    c.hole_filling->iterations = hole_fill;
  }
  if (kalman) c.kalman = KalmanFilter{};
  return c;
}

namespace {

// Cameras from the site config file (if any), then from --source, each with its filters.
void load_site(const ServeArgs& a, std::vector<std::unique_ptr<FrameSource>>& sources,
               std::vector<FilterConfig>& filters, std::vector<std::string>& names) {
  SourceOptions defaults;
  if (!a.intrinsics.empty()) defaults.intrinsics = parse_pinhole(a.intrinsics);
  if (!a.config.empty()) {
    const std::vector<SiteCamera> cameras = read_site_config(a.config);
    for (const SiteCamera& cam : cameras) {
      const std::string where =
          "site config '" + a.config + "' camera " + std::to_string(sources.size());
      SourceOptions opt = defaults;
      if (cam.intrinsics) opt.intrinsics = *cam.intrinsics;
      if (const auto& pose = cam.world_from_camera) {
        opt.world_from_camera = *pose;
        const Eigen::Vector3d t = pose->translation, r = degrees_from_rotation(pose->rotation);
        spdlog::info(
            "camera {}: placed by the site config at ({:.3f}, {:.3f}, {:.3f}) m, turned "
            "({:.2f}, {:.2f}, {:.2f}) deg",
            sources.size(), t.x(), t.y(), t.z(), r.x(), r.y(), r.z());
      }
      FilterConfig f = a.filters.to_config(sources.size());
      if (!cam.filters_json.empty()) {
        try {
          apply_filter_json(cam.filters_json, f);
        } catch (const Error& e) {
          throw Error(where + ": " + e.what());
        }
      }
      const std::string name =
          cam.name.empty() ? "camera " + std::to_string(sources.size()) : cam.name;
      sources.push_back(open_source(resolve_site_source(cam.source, a.config), opt));
      filters.push_back(f);
      names.push_back(name);
    }
  }
  for (const auto& path : a.sources) {
    filters.push_back(a.filters.to_config(sources.size()));
    names.push_back("camera " + std::to_string(sources.size()));
    sources.push_back(open_source(path, defaults));
  }
}

CameraPassOptions pass_options(const ViewArgs& a) {
  CameraPassOptions pass;
  pass.surface = parse_surface(a.surface);
  pass.splat_size = a.splat_size == "fixed"       ? SplatSize::kFixedPixels
                    : a.splat_size == "footprint" ? SplatSize::kFootprint
                                                  : SplatSize::kAdaptive;
  pass.fixed_point_px = a.point_size;
  pass.splat_scale = a.splat_scale;
  pass.max_edge_ratio = a.edge_ratio;
  pass.blend = !a.no_blend;
  return pass;
}

// The presenter for a viewer with a display: OpenXR with --xr when a runtime is available, else
// the desktop window; empty (headless) when no window can be opened. Each fallback is one line.
Presenter interactive_presenter(const ViewArgs& a, const ViewerOptions& opt) {
  std::string why;
  const bool xr = a.xr && xr_available(&why);
  if (a.xr && !xr) spdlog::warn("OpenXR: {}; opening the desktop window", why);
  if (!desktop_available(&why)) {  // OpenXR needs the display too, for its OpenGL context
    spdlog::warn("no display for a window ({}); rendering headless", why);
    return {};
  }
  if (xr) {
    XrOptions options;
    options.pass = opt.pass;
    options.avatar_filter = opt.avatar_filter;
    options.view = opt.view;
    return xr_presenter(options);
  }
  DesktopOptions desktop;
  desktop.width = opt.width;
  desktop.height = opt.height;
  desktop.pass = opt.pass;
  desktop.avatar_filter = opt.avatar_filter;
  desktop.view = opt.view;
  desktop.screenshot = a.screenshot;
  if (!a.site_config.empty()) desktop.site_config = a.site_config;
  return desktop_presenter(desktop);
}

// A participant of session --join: its SessionClient (pose script, camera upload), joined once
// connected, and a presenter that draws the virtual OR from its eye: the desktop window (the eye
// moved by mouse and keyboard is published as the head pose) or, headless or without a display,
// the scripted eye offscreen.
std::unique_ptr<SessionClient> join_session(const ViewArgs& a, ViewerOptions& opt) {
  if (a.name.empty()) throw Error("view: --join needs --name (your display name in the session)");
  std::string why;
  const bool window = opt.render && !a.headless && desktop_available(&why);
  if (opt.render && !a.headless && !window)
    spdlog::warn("no display for a window ({}); rendering the participant's eye headless", why);
  std::string xr_why;
  const bool xr = window && a.xr && xr_available(&xr_why);
  if (window && a.xr && !xr) spdlog::warn("OpenXR: {}; opening the desktop window", xr_why);
  SessionClientOptions s;
  s.participant.session = a.join;
  s.participant.name = a.name;
  s.pose_rate_hz = a.pose_rate;
  s.drive_poses = !window;  // the window (or headset) publishes its eye
  if (!a.pose_script.empty()) s.script = read_pose_script(a.pose_script);
  s.camera_source = a.camera;
  s.upload_depth_codec = a.upload_codec;
  s.upload_color_codec = a.upload_color;
  if (!a.camera_intrinsics.empty())
    s.camera_options.intrinsics = parse_pinhole(a.camera_intrinsics);
  if (!a.camera_pose.empty()) {
    const auto p = parse_numbers(a.camera_pose, 6, "--camera-pose");
    RigidTransform t;
    t.translation = {p[0], p[1], p[2]};
    t.rotation = rotation_from_degrees({p[3], p[4], p[5]});
    s.playarea_from_camera = t;
  }
  auto session = std::make_unique<SessionClient>(std::move(s));
  SessionClient* client = session.get();
  const std::string session_name = a.join;
  opt.on_connected = [client](Client& c) { client->start(c); };
  opt.on_finished = [client, session_name](ViewerResult& r) {
    client->stop();
    if (Participant* p = client->participant()) {
      r.session = p->stats();
      r.session_name = session_name;
    }
  };
  SessionSceneOptions scene;
  scene.pass = opt.pass;
  scene.keep_radius_m = a.avatar_radius;
  scene.room = !a.no_room;
  const auto participant = [client] { return client->participant(); };
  if (xr) {
    XrOptions options;
    options.pass = opt.pass;
    options.participant = participant;
    options.scene = scene;
    opt.presenter = xr_presenter(options);
  } else if (window) {
    DesktopOptions desktop;
    desktop.width = opt.width;
    desktop.height = opt.height;
    desktop.pass = opt.pass;
    desktop.view = opt.view;
    desktop.screenshot = a.screenshot;
    desktop.participant = participant;
    desktop.scene = scene;
    desktop.title = "volcast: " + a.name + " in " + a.join;
    opt.presenter = desktop_presenter(desktop);
  } else if (opt.render) {
    opt.presenter = session_presenter(opt, participant, scene,
                                      opt.software_render_fps > 0 ? opt.software_render_fps : 15);
  }
  return session;
}

}  // namespace

// The server's security settings from the flags: TLS identity (made on first run), join token,
// policy limits. Logs where the identity comes from.
static void apply_security(const ServeArgs& a, ServerConfig& config) {
  config.insecure = a.insecure;
  if (!a.insecure) {
    if (a.cert.empty() != a.key.empty()) throw Error("serve: --cert and --key go together");
    if (!a.cert.empty()) {
      config.identity = load_identity(a.cert, a.key);
    } else {
      const auto dir = user_config_dir() / "server";
      bool created = false;
      config.identity = load_or_create_identity(dir, &created);
      if (created)
        spdlog::info("made a self-signed TLS certificate in {} (kept for later runs)",
                     dir.string());
    }
  }
  if (!a.token_file.empty()) config.token = read_token_file(a.token_file);
  config.offered_tiers = a.tiers;
  config.tier_cpu_budget = a.tier_cpu_budget;
  config.max_tiers_per_address = a.max_tiers_per_address;
  config.handshake_timeout_ms = a.handshake_timeout_ms;
  config.max_pending = a.max_pending;
  config.max_pending_per_address = a.max_pending_per_address;
  if (a.web || !a.web_root.empty())
    config.web_root = a.web_root.empty() ? web_root_default() : std::filesystem::path(a.web_root);
}

void write_link_file(const ServeArgs& a, const std::string& link) {
  if (a.link_file.empty()) return;
  const std::filesystem::path file(a.link_file), temporary(a.link_file + ".tmp");
  write_private_file(temporary, link + "\n");
  std::error_code ec;
  std::filesystem::rename(temporary, file, ec);
  if (ec) throw Error("--link-file: cannot write '" + a.link_file + "': " + ec.message());
}

// The host for the join link: --link-host, else the bind address, else (bound to all addresses)
// this host's first non-loopback address.
std::string link_host(const ServeArgs& a) {
  if (!a.link_host.empty()) return a.link_host;
  const std::string bound = resolve_bind_address(a.bind);
  if (bound != "0.0.0.0" && bound != "::") return a.bind;
  ifaddrs* list = nullptr;
  std::string found = "HOST";
  if (::getifaddrs(&list) == 0) {
    for (ifaddrs* i = list; i; i = i->ifa_next) {
      if (!i->ifa_addr || i->ifa_addr->sa_family != AF_INET) continue;
      char text[INET_ADDRSTRLEN];
      const auto* in = reinterpret_cast<const sockaddr_in*>(i->ifa_addr);
      if (!inet_ntop(AF_INET, &in->sin_addr, text, sizeof text)) continue;
      if (std::string(text).starts_with("127.")) continue;
      found = text;
      break;
    }
    ::freeifaddrs(list);
  }
  return found;
}

// The draw pass settings the view flags give, shared by the window, the headset and headless.

ServerConfig server_config(const ServeArgs& a) {
  ServerConfig config;
  if (a.camera_only) {  // no viewers: the server only feeds the NATS publisher's taps
    if (a.web || a.insecure || a.port != ServeArgs{}.port || a.bind != ServeArgs{}.bind)
      throw Error(
          "serve: a capture node (--camera-only) has no viewers: drop --web, --insecure, "
          "--port and --bind");
    config.insecure = true;
    config.bind_address = "127.0.0.1";
    config.port = 0;
    return config;
  }
  apply_security(a, config);
  config.bind_address = a.bind;
  config.port = a.port;
  config.key_frame_interval = a.key_frame_interval;
  config.max_viewers = a.max_viewers;
  config.max_window = a.max_window;
  config.latency_budget_ms = a.latency_budget_ms;
  config.min_key_interval_ms = a.min_key_interval_ms;
  if (!is_loopback_address(a.bind))
    spdlog::warn(
        "listening on {} beyond this host: anyone who can reach it can try to join; only "
        "holders of the join link get in",
        a.bind);
  return config;
}

std::filesystem::path web_root_default() {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path exe_dir = fs::read_symlink("/proc/self/exe", ec).parent_path();
  // The build tree (build/PRESET/volcast), then an install (bin/volcast).
  const fs::path built = exe_dir / "share/volcast/web",
                 installed = exe_dir / "../share/volcast/web";
  for (const fs::path& p : {built, installed})
    if (!ec && fs::exists(p / "index.html", ec)) return fs::weakly_canonical(p);
  throw Error("the browser viewer is not built: no index.html in " + built.string() + " or " +
              installed.string() +
              " (it needs Debian's emscripten: bash scripts/install-deps.sh, then build again; or "
              "pass --web-root)");
}

std::unique_ptr<CpuLatencyRequest> hold_low_latency(bool on) {
  if (!on) return nullptr;
  auto request = std::make_unique<CpuLatencyRequest>(0);
  if (request->active())
    spdlog::info("--low-latency: idle cores kept awake (CPU wake-up latency held at 0 us)");
  else
    spdlog::warn("--low-latency has no effect: {}", request->error());
  return request;
}

// The first line of `path` (a password file), without its line end. Throws Error naming `flag`.
static std::string read_first_line(const std::string& path, const char* flag) {
  std::ifstream in(path);
  std::string line;
  if (path.empty() || !in || !std::getline(in, line) || line.empty())
    throw Error(std::string(flag) + ": cannot read a first line from '" + path + "'");
  if (!line.empty() && line.back() == '\r') line.pop_back();
  return line;
}

cluster::NatsOptions nats_options(const ServeArgs& a, const std::string& name) {
  cluster::NatsOptions o;
  o.urls = cluster::parse_nats_urls(a.nats);
  o.name = name;
  if (!a.nats_user.empty()) {
    o.user = a.nats_user;
    o.password = read_first_line(a.nats_password_file, "--nats-password-file");
  } else if (!a.nats_password_file.empty()) {
    throw Error("--nats-password-file goes with --nats-user");
  }
  if (a.nats_ca.empty() && !(a.nats_tls_name.empty() && a.nats_cert.empty() && a.nats_key.empty()))
    throw Error("--nats-tls-name, --nats-cert and --nats-key go with --nats-ca");
  o.ca_file = a.nats_ca;
  o.tls_name = a.nats_tls_name;
  o.cert_file = a.nats_cert;
  o.key_file = a.nats_key;
  if (!o.ca_file.empty() && o.tls_name.empty())
    spdlog::warn(
        "NATS TLS: node certificates are checked against {} but not by name: give "
        "--nats-tls-name to require the name they carry",
        o.ca_file);
  if (o.ca_file.empty() && !o.user.empty())
    spdlog::warn(
        "NATS: the password of '{}' goes to the cluster in clear text: give --nats-ca "
        "for TLS",
        o.user);
  return o;
}

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

int run_serve(const ServeArgs& a) {
  const auto low_latency = hold_low_latency(a.low_latency);
  std::vector<std::unique_ptr<FrameSource>> sources;
  std::vector<FilterConfig> filters;
  std::vector<std::string> names;
  std::optional<ReplayPlayer> replay;
  // NATS (publishing, capture nodes) outlives the capture nodes' subscriptions, which outlive the
  // site that reads them.
  std::optional<cluster::NatsConnection> nats;
  std::vector<std::unique_ptr<cluster::RemoteSite>> nodes;
  if ((!a.nats_cameras.empty() || a.camera_only) && a.nats.empty())
    throw Error("serve: --nats-cameras and --camera-only need --nats");
  if (!a.nats.empty()) nats.emplace(nats_options(a, "volcast serve " + a.nats_site));
  std::optional<SitePlayer> site;
  if (replaying(a)) {
    replay.emplace(a.sources[0], ReplayOptions{a.from_s, a.to_s, !a.no_loop});
    const RecordingInfo& info = replay->info();
    spdlog::info(
        "replaying {}: {} frame sets, {:.1f} s, tier {}/{} (passed through as "
        "recorded to viewers of that tier){}",
        a.sources[0], info.frame_sets.size(),
        static_cast<double>(replay->timeline().duration_us()) / 1e6, info.stream.depth_codec,
        info.stream.color_codec,
        info.closed ? "" : "; not closed by its recorder, indexed by scanning");
    for (const auto& c : replay->cameras()) {
      names.push_back(c.description);
      filters.emplace_back();
    }
  } else {
    load_site(a, sources, filters, names);
    for (const std::string& node : a.nats_cameras) {
      cluster::RemoteSiteOptions o;
      o.site = node;
      std::tie(o.depth_codec, o.color_codec, o.color_quality) =
          parse_tier(a.nats_camera_tier, "--nats-camera-tier");
      o.fps = a.fps > 0 ? a.fps : 30;
      nodes.push_back(std::make_unique<cluster::RemoteSite>(*nats, o));
      auto node_sources = nodes.back()->sources();
      for (size_t i = 0; i < node_sources.size(); ++i) {
        names.push_back(node + ": " + nodes.back()->cameras()[i].description);
        sources.push_back(std::move(node_sources[i]));
        filters.emplace_back();  // filtered on the node
      }
    }
    if (sources.empty())
      throw Error("serve: give at least one --source, a --config with cameras or --nats-cameras");
  }
  std::vector<std::string> color_notes(names.size());  // per camera: ", no color" etc.
  for (size_t i = 0; i < sources.size(); ++i) {
    const int color = sources[i]->color_frame_count(), frames = sources[i]->frame_count();
    color_notes[i] = color == 0 ? ", NO COLOR (depth only)"
                     : color < frames
                         ? fmt::format(", no color in {} of {} frames", frames - color, frames)
                         : "";
  }
  if (!replay) site.emplace(std::move(sources), a.fps, filters, SiteOptions{a.max_read_failures});
  auto cameras = replay ? replay->cameras() : site->cameras();
  for (size_t i = 0; i < cameras.size(); ++i) {
    const auto& k = cameras[i].calibration.depth;
    spdlog::info("camera {}: {} (sent as {}x{}, fx {:.1f} fy {:.1f} cx {:.1f} cy {:.1f}{}{}{})", i,
                 cameras[i].description, k.width, k.height, k.fx, k.fy, k.cx, k.cy,
                 k.is_pinhole() ? ", pinhole" : ", Brown-Conrady",
                 filters[i].any() ? ", filtered" : "", color_notes[i]);
  }
  std::vector<protocol::CameraInfo> for_viewers = cameras;  // names, never file paths
  for (size_t i = 0; i < cameras.size(); ++i) for_viewers[i].description = names[i];
  ServerConfig config = server_config(a);
  SessionHubConfig hub_config;
  hub_config.site_name = a.site_name;
  hub_config.presence_timeout_ms = a.presence_timeout_ms;
  if (!a.room_from_site.empty()) {
    const auto r = parse_numbers(a.room_from_site, 4, "--room-from-site");
    hub_config.site_translation = Eigen::Vector3d(r[0], r[1], r[2]).cast<float>();
    hub_config.site_yaw = static_cast<float>(r[3] * M_PI / 180);
  }
  SessionHub hub(hub_config);
  for (const auto& name : a.sessions) hub.create_session(name);
  std::optional<CaseWatch> case_watch;
  if (!a.case_folder.empty()) case_watch.emplace(a.case_folder, hub, a.case_max_triangles);
  config.session = &hub;
  std::optional<BackgroundRecorder> recorder;        // outlives the server, whose tier feeds it
  std::optional<cluster::TierPublisher> publisher;   // so does this
  std::optional<cluster::SessionBridge> bridge;      // relays' participants, to the hub
  std::optional<cluster::SessionStateMirror> state;  // the hub's state, in a NATS bucket
  Server server(for_viewers, config);
  hub.attach(&server);
  if (!a.record.empty()) {
    RecordingStream stream;
    std::tie(stream.depth_codec, stream.color_codec, stream.color_quality) =
        parse_tier(a.record_tier, "--record-tier");
    stream.started_us = wall_clock_us();
    stream.origin = "volcast serve --record";
    stream.welcome = {for_viewers, wall_clock_us()};
    recorder.emplace(a.record, stream);
    server.add_tier_tap(stream.depth_codec, stream.color_codec, stream.color_quality,
                        [&recorder](const TierFrameSet& f) { recorder->push(f); });
    spdlog::info("recording tier {} to {}", a.record_tier, a.record);
  }
  // The stream on a NATS cluster: one more consumer of each published tier's encoding.
  if (nats) {
    publisher.emplace(*nats, a.nats_site, protocol::Welcome{for_viewers, wall_clock_us()});
    for (const std::string& t : a.nats_tiers) {
      const auto [depth, color, quality] = parse_tier(t, "--nats-tier");
      publisher->publish_tier(server, depth, color, quality);
      spdlog::info("offering tier {} on NATS as {} (encoded and published while a relay wants it)",
                   t, cluster::tier_subject(a.nats_site, depth, color, quality));
    }
    if (!a.camera_only) {  // participants of relays join this hub's sessions
      try {
        bridge.emplace(*nats, a.nats_site, hub);
        hub.attach_remote(&*bridge);
      } catch (const Error& e) {  // e.g. the account may not subscribe: the stream goes on
        spdlog::warn("viewers of relays cannot join the sessions: {}", e.what());
      }
      if (a.nats_state_replicas > 0) try {
          state.emplace(*nats, a.nats_site, hub, a.nats_state_replicas);
          spdlog::info("sessions' state kept in NATS bucket {} ({} restored)",
                       cluster::session_state_bucket(a.nats_site), state->stats().restored);
        } catch (const Error& e) {
          spdlog::warn("sessions' state not kept on NATS: {}", e.what());
        }
    }
  }
  if (replay)
    replay->start(server);
  else
    site->start(server);
  spdlog::info("serving {} camera(s) at {:.1f} fps on {}:{} ({}; Ctrl-C stops)", cameras.size(),
               replay ? replay->fps() : site->fps(), a.bind, server.port(),
               a.insecure ? "plain TCP, loopback only" : "TLS 1.3");
  if (!a.camera_only)
    spdlog::info("tiers may use {:.1f} CPU cores to encode (--tier-cpu-budget)",
                 server.tier_cpu_budget());
  if (a.camera_only)
    std::printf(
        "capture node: %zu camera(s) published on NATS as site '%s' (a site server adds "
        "them with --nats-cameras %s)\n",
        cameras.size(), a.nats_site.c_str(), a.nats_site.c_str());
  else if (!a.insecure)
    spdlog::info("certificate SHA-256 fingerprint: {}", server.fingerprint());
  if (!a.camera_only) {
    std::printf("join link (give it only to the viewers of this session):\n  %s\n",
                server.join_link(link_host(a)).c_str());
    write_link_file(a, server.join_link(link_host(a)));
  }
  if (!config.web_root.empty())
    std::printf("browser link (any headset's or laptop's browser; accept the certificate):\n  %s\n",
                server.web_link(link_host(a)).c_str());
  std::fflush(stdout);
  const auto start = std::chrono::steady_clock::now();
  auto last_report = start;
  while (!g_interrupted) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    const auto now = std::chrono::steady_clock::now();
    if (a.seconds > 0 && now - start > std::chrono::duration<double>(a.seconds)) break;
    if (replay && replay->finished()) {
      spdlog::info("the recording has played to its end (--no-loop)");
      break;
    }
    if (now - last_report > std::chrono::seconds(5)) {
      last_report = now;
      int connected = 0;
      for (const auto& v : server.viewers()) connected += v.connected;
      std::string failed;  // cameras that cannot be read now
      const auto status = site ? site->camera_status() : std::vector<CameraStatus>{};
      for (size_t i = 0; i < status.size(); ++i)
        if (status[i].failed) failed += fmt::format("{}{}", failed.empty() ? "" : ", ", i);
      std::string recording;
      if (recorder) {
        const RecorderStats r = recorder->stats();
        recording = fmt::format("; recorded {} frame sets, {:.1f} MB{}{}", r.frame_sets,
                                static_cast<double>(r.bytes) / 1e6,
                                r.dropped ? fmt::format(", {} dropped", r.dropped) : "",
                                r.error.empty() ? "" : " -- STOPPED: " + r.error);
      }
      if (publisher) {
        const cluster::PublisherStats p = publisher->stats();
        recording += fmt::format(
            "; NATS {} frame sets, {:.1f} MB{}", p.frame_sets, static_cast<double>(p.bytes) / 1e6,
            p.errors ? fmt::format(", {} lost ({})", p.errors, p.last_error) : "");
      }
      spdlog::info(
          "{} frame sets published, {} viewer(s) connected{}{}",
          replay ? replay->frame_sets_published() : site->frame_sets_published(), connected,
          failed.empty() ? "" : "; FAILED camera(s) " + failed + " (last good frame)", recording);
    }
  }
  // The sessions' last state is written while they are as the participants left them: stopping
  // the server ends every participant's session, which would delete their states.
  state.reset();
  if (site) site->stop();
  if (replay) replay->stop();
  server.stop();
  if (recorder) {
    recorder->stop();
    const RecorderStats r = recorder->stats();
    std::printf("recorded %llu frame sets, %.1f MB, to %s%s\n",
                static_cast<unsigned long long>(r.frame_sets), static_cast<double>(r.bytes) / 1e6,
                recorder->path().c_str(), r.error.empty() ? "" : (" -- " + r.error).c_str());
  }
  hub.attach(nullptr);
  hub.attach_remote(nullptr);
  bridge.reset();
  const SessionHubStats hs = hub.stats();
  spdlog::info(
      "sessions: {} joins, {} left, {} timed out, {} dropped; {} poses in, {} out; {} "
      "avatar frames in, {} out ({:.1f} MB)",
      hs.joins, hs.leaves, hs.timeouts, hs.dropped, hs.poses_in, hs.pose_messages_out,
      hs.avatar_frames_in, hs.avatar_frames_out, double(hs.avatar_bytes_out) / 1e6);
  for (const auto& v : server.viewers())
    spdlog::info(
        "viewer {} ({}/{}): {} frame sets sent, {} skipped ({} over the latency budget), {:.1f} "
        "MB, "
        "path RTT {:.1f} ms, {:.1f} Mbit/s",
        v.peer, v.depth_codec, v.color_codec, v.frames_sent, v.frames_dropped, v.frames_stale,
        static_cast<double>(v.bytes_sent) / 1e6, v.min_rtt_ms, v.bottleneck_mbit_s);
  return 0;
}

namespace {

constexpr size_t kMaxLinkFileBytes = 4096;

// The join link in `text` (a file's or standard input's): its first line that is neither empty
// nor a comment, without surrounding blanks. Throws Error naming `where` if there is none.
std::string link_in(const std::string& text, const std::string& command, const std::string& where) {
  if (text.size() > kMaxLinkFileBytes)
    throw Error(command + ": " + where + " is over " + std::to_string(kMaxLinkFileBytes) +
                " bytes: not a join link");
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);) {
    const size_t begin = line.find_first_not_of(" \t\r");
    if (begin == std::string::npos || line[begin] == '#') continue;
    return line.substr(begin, line.find_last_not_of(" \t\r") + 1 - begin);
  }
  throw Error(command + ": " + where + " holds no join link");
}

// --connect, or the link read from --connect-file or standard input (--connect -).
std::string connect_target(const std::string& command, const std::string& connect,
                           const std::string& connect_file) {
  if (!connect_file.empty() && !connect.empty())
    throw Error(command + ": give --connect or --connect-file, not both");
  if (connect_file.empty() && connect != "-") {
    if (connect.empty())
      throw Error(command +
                  ": say where to connect: --connect LINK, --connect-file FILE, or --connect - "
                  "(the link on standard input)");
    return connect;
  }
  std::string text(kMaxLinkFileBytes + 1, '\0');
  if (connect == "-") {
    std::cin.read(text.data(), static_cast<std::streamsize>(text.size()));
    text.resize(static_cast<size_t>(std::cin.gcount()));
    return link_in(text, command, "standard input");
  }
  std::ifstream in(connect_file, std::ios::binary);
  if (!in) throw Error(command + ": cannot read --connect-file '" + connect_file + "'");
  in.read(text.data(), static_cast<std::streamsize>(text.size()));
  text.resize(static_cast<size_t>(in.gcount()));
  struct stat st {};
  if (::stat(connect_file.c_str(), &st) == 0 && (st.st_mode & 077))
    spdlog::warn(
        "{}: '{}' may be read by other users (mode {:04o}), and its token lets them join: chmod "
        "600 it",
        command, connect_file, st.st_mode & 07777);
  return link_in(text, command, "'" + connect_file + "'");
}

}  // namespace

ClientConfig connect_client_config(const std::string& command, const std::string& connect_flag,
                                   const std::string& connect_file, const std::string& token,
                                   const std::string& fingerprint, bool insecure,
                                   const std::string& known_servers) {
  const std::string connect = connect_target(command, connect_flag, connect_file);
  ClientConfig c;
  if (is_join_link(connect)) {
    if (!token.empty() || !fingerprint.empty())
      throw Error(command +
                  ": the join link holds the token and fingerprint; drop --token/--fingerprint");
    c = client_config_from_link(connect);
  } else {
    std::tie(c.host, c.port) = parse_host_port(connect);
    if (token.empty())
      throw Error(command + ": --connect HOST:PORT needs --token (or give the join link instead)");
    c.token = parse_join_token(token);
    if (!fingerprint.empty()) c.fingerprint = parse_fingerprint(fingerprint);
    c.insecure = insecure;
  }
  if (insecure && !c.insecure)
    throw Error(command + ": --insecure conflicts with a TLS join link (it has fp=)");
  c.known_servers =
      known_servers.empty() ? (user_config_dir() / "known_servers").string() : known_servers;
  return c;
}

int run_view(const ViewArgs& a) {
  const auto low_latency = hold_low_latency(a.low_latency);
  ViewerOptions opt;
  opt.client = connect_client_config("view", a.connect, a.connect_file, a.token, a.fingerprint,
                                     a.insecure, a.known_servers);
  opt.client.connect_timeout_ms = a.connect_timeout_ms;
  opt.client.depth_codec = a.depth_codec;
  opt.client.color_codec = a.color_codec;
  opt.client.color_quality = a.color_quality;
  opt.client.handshake_timeout_ms = a.handshake_timeout_ms;
  opt.client.receive_timeout_ms = a.receive_timeout_ms;
  opt.frames = a.frames;
  opt.seconds = a.seconds;
  opt.render = !a.no_render;
  const size_t x = a.size.find('x');
  if (x == std::string::npos) throw Error("--size expects WIDTHxHEIGHT, e.g. 1280x720");
  const auto wh = parse_numbers(a.size.substr(0, x) + "," + a.size.substr(x + 1), 2, "--size");
  opt.width = static_cast<int>(wh[0]);
  opt.height = static_cast<int>(wh[1]);
  if (!a.eye.empty() || !a.target.empty()) {
    if (a.eye.empty() || a.target.empty()) throw Error("--eye and --target go together");
    const auto e = parse_numbers(a.eye, 3, "--eye");
    const auto t = parse_numbers(a.target, 3, "--target");
    ViewCamera v;
    v.eye = Eigen::Vector3d(e[0], e[1], e[2]).cast<float>();
    v.target = Eigen::Vector3d(t[0], t[1], t[2]).cast<float>();
    opt.view = v;
  }
  if (!a.keep_within.empty()) {
    const auto k = parse_numbers(a.keep_within, 4, "--keep-within");
    if (!(k[3] > 0)) throw Error("--keep-within: the radius must be positive metres");
    opt.avatar_filter.keep =
        KeepSphere{Eigen::Vector3d(k[0], k[1], k[2]).cast<float>(), static_cast<float>(k[3])};
  }
  if (!a.hide_headset.empty()) {
    const bool yaw = std::count(a.hide_headset.begin(), a.hide_headset.end(), ',') == 3;
    const auto h = parse_numbers(a.hide_headset, yaw ? 4 : 3, "--hide-headset");
    HideBox box;
    box.world_from_headset.translation = {h[0], h[1], h[2]};
    if (yaw)
      box.world_from_headset.rotation =
          Eigen::AngleAxisd(h[3] * M_PI / 180, Eigen::Vector3d::UnitY()).toRotationMatrix();
    opt.avatar_filter.hide = box;
  }
  opt.pass = pass_options(a);
  opt.screenshot = a.screenshot;
  opt.save_frames_dir = a.save_frames;
  opt.stats_json = a.stats_json;
  opt.stop = &g_interrupted;
  std::unique_ptr<SessionClient> session;
  if (!a.join.empty()) session = join_session(a, opt);
  if (opt.render && !a.headless && !session) opt.presenter = interactive_presenter(a, opt);
  ViewerResult result;
  try {
    result = run_viewer(opt);
  } catch (const ViewerError& e) {
    std::printf("%s", format_stats_table(e.result()).c_str());
    std::fflush(stdout);
    throw;  // main reports the error; exit 1
  }
  std::printf("%s", format_stats_table(result).c_str());
  std::fflush(stdout);
  if (result.frame_sets_received == 0)
    throw Error(std::string("no frame set received (") + to_string(result.ended) + ")");
  return 0;
}

}  // namespace volcast
