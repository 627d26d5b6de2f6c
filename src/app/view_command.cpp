// volcast view: a site's stream in a window, a headset or offscreen, optionally as a participant
// of a virtual-OR session; and how every client command reads where to connect.
#include <spdlog/spdlog.h>
#include <sys/stat.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <fstream>
#include <iostream>
#include <sstream>

#include "cli.hpp"
#include "commands.hpp"
#include "options.hpp"
#include "volcast/codec/color_codec.hpp"
#include "volcast/codec/depth_codec.hpp"
#include "volcast/codec/registry.hpp"
#include "volcast/core/error.hpp"
#include "volcast/io/site_config.hpp"
#include "volcast/net/protocol/join.hpp"
#include "volcast/pipeline/or_display.hpp"
#include "volcast/pipeline/receiver.hpp"
#include "volcast/pipeline/session_client.hpp"
#include "volcast/pipeline/session_scene.hpp"
#include "volcast/viewer/desktop.hpp"
#include "volcast/viewer/or_display_window.hpp"
#include "volcast/viewer/xr.hpp"
#include "volcast/voice/voice_report.hpp"

namespace volcast {
namespace {

// The draw pass settings the view flags give, shared by the window, the headset and headless.
CameraPassOptions pass_options(const ViewArgs& a) {
  CameraPassOptions pass;
  pass.surface = parse_surface(a.surface);
  pass.splat_size = a.splat_size == "fixed"       ? SplatSize::kFixedPixels
                    : a.splat_size == "footprint" ? SplatSize::kFootprint
                                                  : SplatSize::kAdaptive;
  pass.fixed_point_px = a.point_size;
  pass.splat_scale = a.splat_scale;
  pass.max_edge_ratio = a.edge_ratio;
  pass.blend = a.blend != "off";
  return pass;
}

// The desktop window's options that both kinds of view share: size, pass, viewpoint, screenshot.
DesktopOptions desktop_options(const ViewArgs& a, const ViewerOptions& opt) {
  DesktopOptions desktop;
  desktop.width = opt.width;
  desktop.height = opt.height;
  desktop.pass = opt.pass;
  desktop.view = opt.view;
  desktop.screenshot = a.screenshot;
  desktop.blend = parse_blend_policy(a.blend);
  desktop.frame_period_us = int64_t(a.frame_ms * 1000.0);
  return desktop;
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
    options.blend = parse_blend_policy(a.blend);
    options.avatar_filter = opt.avatar_filter;
    options.view = opt.view;
    return xr_presenter(options);
  }
  DesktopOptions desktop = desktop_options(a, opt);
  desktop.avatar_filter = opt.avatar_filter;
  if (!a.site_config.empty()) desktop.site_config = a.site_config;
  return desktop_presenter(desktop);
}

// The voice link's settings from --mic, --speaker, --mute, --push-to-talk, --volume,
// --mono-voices; none without a microphone or loudspeaker.
std::optional<voice::VoiceConfig> voice_options(const ViewArgs& a) {
  if (a.mic.empty() && a.speaker.empty()) return std::nullopt;
  voice::VoiceConfig v;
  v.mic = a.mic;
  v.speaker = a.speaker;
  v.muted = a.mute;
  v.push_to_talk = a.push_to_talk;
  v.spatial = !a.mono_voices;
  for (const std::string& entry : a.volumes) {
    const size_t eq = entry.rfind('=');
    if (eq == std::string::npos || eq == 0)
      throw Error("view: --volume takes NAME=GAIN, not '" + entry + "'");
    const double gain = parse_numbers(entry.substr(eq + 1), 1, "--volume")[0];
    if (!(gain >= 0 && gain <= 4)) throw Error("view: --volume's gain must be 0 to 4: " + entry);
    v.volumes[entry.substr(0, eq)] = static_cast<float>(gain);
  }
  return v;
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
  const bool or_display = a.or_display >= 0;
  if (or_display) s.drive_poses = false;  // it watches: no pose, no avatar of its own
  auto surfaces = std::make_shared<LiveSurfaces>();
  s.surfaces = surfaces;
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
  const auto voice_config = voice_options(a);
  if (voice_config && voice_config->push_to_talk && !voice_config->mic.empty() && !window)
    spdlog::warn(
        "view: --push-to-talk without a window or headset to hold the key: your "
        "microphone sends nothing");
  // Made once connected, before the presenter starts; destroyed once it has returned.
  auto voice = std::make_shared<std::unique_ptr<voice::VoiceLink>>();
  ParticipantLife life;
  life.session_name = session_name;
  life.joined = [voice, voice_config](SessionClient& c) {
    if (voice_config) *voice = std::make_unique<voice::VoiceLink>(*c.participant(), *voice_config);
  };
  life.leaving = [voice, voice_json = a.voice_json](SessionClient&, ViewerResult&) {
    if (!*voice) return;
    (*voice)->stop();
    report_voice((*voice)->stats(), voice_json);
    voice->reset();
  };
  live_in_viewer(*client, opt, std::move(life));
  SessionSceneOptions scene;
  scene.pass = opt.pass;
  scene.keep_radius_m = a.avatar_radius;
  scene.room = !a.no_room;
  const auto participant = [client] { return client->participant(); };
  const auto voice_link = [voice] { return voice->get(); };
  if (or_display) {
    if (!opt.render) throw Error("view: --or-display needs rendering (drop --no-render)");
    if (window) {
      OrDisplayWindowOptions w;
      w.camera = static_cast<size_t>(a.or_display);
      w.width = opt.width;
      w.height = opt.height;
      w.fullscreen = a.fullscreen;
      w.title = "volcast: OR display of camera " + std::to_string(a.or_display) + " in " + a.join;
      w.participant = participant;
      w.screenshot = a.screenshot;
      opt.presenter = or_display_window_presenter(w);
    } else {
      opt.presenter =
          or_display_presenter(opt, static_cast<size_t>(a.or_display), participant,
                               opt.software_render_fps > 0 ? opt.software_render_fps : 15);
    }
  } else if (xr) {
    XrOptions options;
    options.pass = opt.pass;
    options.blend = parse_blend_policy(a.blend);
    options.participant = participant;
    options.scene = scene;
    options.voice = voice_link;
    opt.presenter = xr_presenter(options);
  } else if (window) {
    DesktopOptions desktop = desktop_options(a, opt);
    desktop.participant = participant;
    desktop.scene = scene;
    desktop.voice = voice_link;
    desktop.title = "volcast: " + a.name + " in " + a.join;
    opt.presenter = desktop_presenter(desktop);
  } else if (opt.render) {
    opt.presenter =
        session_presenter(opt, participant, scene,
                          opt.software_render_fps > 0 ? opt.software_render_fps : 15, surfaces);
  }
  return session;
}

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
  opt.client.tier = a.tier;
  opt.client.adapt = !a.tier_pinned;
  for (const auto& f : a.floors) {
    opt.client.keep_lossless |= f == "lossless";
    opt.client.keep_full_rate |= f == "full-rate";
  }
  if (!a.max_rate.empty()) opt.client.max_bits_per_s = parse_bit_rate(a.max_rate, "--max-rate");
  opt.client.handshake_timeout_ms = a.handshake_timeout_ms;
  opt.client.receive_timeout_ms = a.receive_timeout_ms;
  opt.reconnect = !a.no_reconnect && a.receive_timeout_ms > 0;
  opt.reconnect_give_up_s = a.give_up_after_s;
  if (opt.reconnect) opt.stale_ms = 1000;  // a frame a second old is not live: not drawn
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
  if (a.or_display >= 0 && a.join.empty())
    throw Error("view: --or-display needs --join SESSION (it shows that session's participants)");
  if (a.fullscreen && a.or_display < 0)
    throw Error("view: --fullscreen goes with --or-display (the OR's wall monitor)");
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

void register_view(CLI::App& app, Commands& commands) {
  auto [v, view] =
      add_command<ViewArgs>(app, commands, run_view, "view",
                            "Receive a site's stream and watch it in a window (or headset)");
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
  ViewArgs* const pinned = &view;  // a lambda may not capture a structured binding (clang 14)
  const auto pin = [pinned](const std::string&) { pinned->tier_pinned = true; };
  v->add_option("--depth-codec", view.tier.depth_codec,
                "Depth codec, pinning the tier (without it, the server moves this viewer along "
                "its tier ladder as the path allows): " +
                    depth_codec_help())
      ->each(pin);
  v->add_option("--color-codec", view.tier.color_codec,
                "Color codec, pinning the tier: " + color_codec_help())
      ->each(pin);
  v->add_option("--color-quality", view.tier.color_quality,
                "Color quality 1..100, pinning the tier (JPEG quality, H.264 CRF from it; 0 = the "
                "codec default)")
      ->each(pin);
  v->add_option("--floor", view.floors,
                "What adapting to the path may never take away (repeat): lossless (depth is "
                "never lossy) or full-rate (every frame set of the site)")
      ->check(CLI::IsMember({"lossless", "full-rate"}));
  v->add_option("--max-rate", view.max_rate,
                "The most this viewer wants to be sent, bits per second with k, M or G (e.g. 20M)");
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
  v->add_option("--blend", view.blend,
                "Blend overlapping cameras: auto (until a window's or headset's frames take over "
                "1.5 display periods with it, then the depth test picks; the panel says so), on, "
                "or off (the depth test always picks)")
      ->check(CLI::IsMember({"auto", "on", "off"}))
      ->capture_default_str();
  v->add_option("--frame-ms", view.frame_ms,
                "Window: the display period (ms) --blend auto holds frames to (default: the "
                "monitor's refresh rate, 60 Hz where it reports none)")
      ->check(CLI::Range(0.0, 1000.0));
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
                "A connection silent this long (no complete message, ms) is cut: connect again "
                "and rejoin, showing 'reconnecting' (or end, with --no-reconnect; 0 = never)")
      ->capture_default_str();
  v->add_flag("--no-reconnect", view.no_reconnect,
              "End the session when the connection breaks or falls silent, instead of "
              "connecting again with the same link");
  v->add_option("--give-up-after", view.give_up_after_s,
                "Stop reconnecting after a cut this long (seconds)")
      ->capture_default_str();
  v->add_flag("--low-latency", view.low_latency, kLowLatencyHelp);
  v->add_option("--join", view.join,
                "Join this virtual-OR session as a participant (made if there is none)");
  v->add_option("--name", view.name, "Your display name in the session (with --join)");
  v->add_option("--or-display", view.or_display,
                "With --join: be the OR display of site camera N (0 = the first): that camera's "
                "own image, from its viewpoint, with the remote participants, their pointers and "
                "the session's annotations drawn in, hidden by what stands in front; in a window "
                "for the OR's wall monitor (F11 full screen, H legend, F12 screenshot), or with "
                "--headless its last picture written to --screenshot")
      ->check(CLI::NonNegativeNumber);
  v->add_flag("--fullscreen", view.fullscreen,
              "With --or-display: open its window full screen on the primary monitor");
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
  v->add_option("--mic", view.mic,
                "With --join: your microphone, a sound device (\"default\" or part of its name) "
                "or a .wav file (played in real time)");
  v->add_option("--speaker", view.speaker,
                "With --join: where the others' voices play, each from where its speaker stands "
                "(HRTF): a sound device or a .wav file (stereo)");
  v->add_flag("--mute", view.mute, "Start with your microphone muted (the window's M toggles it)");
  v->add_flag("--push-to-talk", view.push_to_talk,
              "Send your microphone only while you hold V (window) or the left controller's X "
              "(headset)");
  v->add_option("--volume", view.volumes,
                "A participant's volume: NAME=GAIN (0 silent, 1 as sent, up to 4; repeat)");
  v->add_flag("--mono-voices", view.mono_voices,
              "Mix the voices to one channel instead of placing them (HRTF)");
  v->add_option("--voice-json", view.voice_json,
                "Write what your voice link sent and heard (mouth-to-ear latency, loss, "
                "concealment per speaker) as JSON");
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
}

}  // namespace volcast
