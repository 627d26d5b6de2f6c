// volcast serve and replay: one site's cameras (or a recording) to viewers, with the virtual OR's
// sessions, the case, a recorder and the NATS cluster as the flags ask.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <Eigen/Geometry>
#include <chrono>
#include <thread>

#include "cli.hpp"
#include "commands.hpp"
#include "options.hpp"
#include "volcast/assets/case_watch.hpp"
#include "volcast/cluster/remote_site.hpp"
#include "volcast/cluster/session_link.hpp"
#include "volcast/cluster/session_state.hpp"
#include "volcast/cluster/tier_publisher.hpp"
#include "volcast/codec/tier.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/text.hpp"
#include "volcast/io/site_config.hpp"
#include "volcast/pipeline/replay.hpp"
#include "volcast/pipeline/sender.hpp"
#include "volcast/record/recorder.hpp"
#include "volcast/session/hub.hpp"
#include "volcast/voice/site_voice.hpp"

namespace volcast {
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

// Everything a running `serve` owns, in one place. The members are declared in the order they are
// made, so they are destroyed in the reverse order, and each outlives what uses it:
// - the NATS connection outlives the capture nodes' subscriptions, which outlive the site (their
//   cameras are the site's sources);
// - the hub outlives the case watch, which shares the case through it, and the server, which
//   serves its sessions (each holds a pointer to it);
// - the recorder and the publisher outlive the server, whose tier taps feed them; the bridge and
//   the state mirror (the hub over NATS) outlive it too;
// - the server goes first: its viewers' threads stop before anything they reach;
// - the --low-latency hold goes last: it covers the whole run, shutdown included.
// stop_serving() stops them, in the order that keeps the sessions' state, before they go.
struct Serving {
  std::unique_ptr<CpuLatencyRequest> low_latency;
  std::optional<ReplayPlayer> replay;
  std::optional<cluster::NatsConnection> nats;
  std::vector<std::unique_ptr<cluster::RemoteSite>> nodes;
  std::optional<SitePlayer> site;
  std::vector<protocol::CameraInfo> cameras;  ///< as viewers see them: names, never file paths
  std::optional<SessionHub> hub;
  std::unique_ptr<voice::SiteVoice> voice;  ///< --mic, --speaker: the OR speaks and listens
  std::atomic<voice::SiteVoice*> listening{nullptr};
  std::optional<CaseWatch> case_watch;
  std::optional<BackgroundRecorder> recorder;
  std::optional<cluster::TierPublisher> publisher;
  std::optional<cluster::SessionBridge> bridge;      ///< relays' participants, to the hub
  std::optional<cluster::SessionStateMirror> state;  ///< the hub's state, in a NATS bucket
  std::optional<Server> server;
};

// The cameras: a recording replayed, or the site's sources (--config, --source) and the capture
// nodes' cameras (--nats-cameras) in a SitePlayer; logs each.
void open_cameras(const ServeArgs& a, Serving& s) {
  std::vector<std::unique_ptr<FrameSource>> sources;
  std::vector<FilterConfig> filters;
  std::vector<std::string> names;
  if ((!a.nats_cameras.empty() || a.camera_only) && a.nats.empty())
    throw Error("serve: --nats-cameras and --camera-only need --nats");
  if (!a.nats.empty()) s.nats.emplace(nats_options(a, "volcast serve " + a.nats_site));
  if (replaying(a)) {
    s.replay.emplace(a.sources[0], ReplayOptions{a.from_s, a.to_s, !a.no_loop});
    const RecordingInfo& info = s.replay->info();
    spdlog::info(
        "replaying {}: {} frame sets, {:.1f} s, tier {} (passed through as "
        "recorded to viewers of that tier){}",
        a.sources[0], info.frame_sets.size(),
        static_cast<double>(s.replay->timeline().duration_us()) / 1e6, to_string(info.stream.tier),
        info.closed ? "" : "; not closed by its recorder, indexed by scanning");
    for (const VoicePlan::Speaker& v : s.replay->voices().speakers)
      spdlog::info("replaying the voice of '{}': {} packets (as '{} (recorded)' in the sessions)",
                   printable(v.speaker.name), v.packets, printable(v.speaker.name));
    for (const auto& c : s.replay->cameras()) {
      names.push_back(c.description);
      filters.emplace_back();
    }
  } else {
    load_site(a, sources, filters, names);
    for (const std::string& node : a.nats_cameras) {
      cluster::RemoteSiteOptions o;
      o.site = node;
      o.tier = parse_tier(a.nats_camera_tier, "--nats-camera-tier", TierRate::kEveryFrameSet);
      o.fps = a.fps > 0 ? a.fps : 30;
      s.nodes.push_back(std::make_unique<cluster::RemoteSite>(*s.nats, o));
      auto node_sources = s.nodes.back()->sources();
      for (size_t i = 0; i < node_sources.size(); ++i) {
        names.push_back(node + ": " + s.nodes.back()->cameras()[i].description);
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
  if (!s.replay) {
    SiteOptions site_options;
    site_options.max_read_failures = a.max_read_failures;
    s.site.emplace(std::move(sources), a.fps, filters, std::move(site_options));
  }
  auto cameras = s.replay ? s.replay->cameras() : s.site->cameras();
  for (size_t i = 0; i < cameras.size(); ++i) {
    const auto& k = cameras[i].calibration.depth;
    spdlog::info("camera {}: {} (sent as {}x{}, fx {:.1f} fy {:.1f} cx {:.1f} cy {:.1f}{}{}{})", i,
                 cameras[i].description, k.width, k.height, k.fx, k.fy, k.cx, k.cy,
                 k.is_pinhole() ? ", pinhole" : ", Brown-Conrady",
                 filters[i].any() ? ", filtered" : "", color_notes[i]);
  }
  s.cameras = cameras;
  for (size_t i = 0; i < cameras.size(); ++i) s.cameras[i].description = names[i];
}

// The virtual OR's sessions (and the case shown in them), then the server that serves them.
void open_server(const ServeArgs& a, const ServerConfig& base, Serving& s) {
  ServerConfig config = base;
  SessionHubConfig hub_config;
  hub_config.site_name = a.site_name;
  hub_config.presence_timeout_ms = a.presence_timeout_ms;
  if (!a.room_from_site.empty()) {
    const auto r = parse_numbers(a.room_from_site, 4, "--room-from-site");
    hub_config.site_translation = Eigen::Vector3d(r[0], r[1], r[2]).cast<float>();
    hub_config.site_yaw = static_cast<float>(r[3] * M_PI / 180);
  }
  if (!a.mic.empty() || !a.speaker.empty())
    hub_config.site_listener = [&s](uint32_t id, const session::VoicePacketView& p) {
      if (voice::SiteVoice* v = s.listening.load()) v->put(id, p);
    };
  SessionHub& hub = s.hub.emplace(hub_config);
  for (const auto& name : a.sessions) hub.create_session(name);
  if (!a.mic.empty() || !a.speaker.empty()) {
    voice::SiteVoiceConfig v;
    v.echo_cancellation = !a.no_echo_cancellation;
    s.voice = std::make_unique<voice::SiteVoice>(
        v, a.mic.empty() ? nullptr : voice::open_microphone(a.mic),
        a.speaker.empty() ? nullptr : voice::open_speaker(a.speaker, 1),
        [&hub](const session::VoicePacketView& p) { hub.site_voice(p); });
    s.listening = s.voice.get();
    spdlog::info(
        "the OR's voice: microphone {}, loudspeaker {}{}", a.mic.empty() ? "none" : a.mic,
        a.speaker.empty() ? "none" : a.speaker,
        v.echo_cancellation && !a.mic.empty() && !a.speaker.empty() ? ", echo cancelled" : "");
  }
  if (!a.case_folder.empty())
    s.case_watch.emplace(
        a.case_folder, [&hub](SharedCase c) { hub.set_case(std::move(c)); }, a.case_max_triangles);
  config.session = &hub;
  s.server.emplace(s.cameras, config);
  hub.attach(&*s.server);
}

// What else takes the stream: the recorder (--record) and the NATS cluster (--nats: published
// tiers, the relays' participants, the sessions' state).
void add_outlets(const ServeArgs& a, Serving& s) {
  Server& server = *s.server;
  if (!a.record.empty()) {
    RecordingStream stream;
    stream.tier = parse_tier(a.record_tier, "--record-tier", TierRate::kEveryFrameSet);
    stream.started_us = wall_clock_us();
    stream.origin = "volcast serve --record";
    stream.welcome = {s.cameras, wall_clock_us()};
    BackgroundRecorder& recorder = s.recorder.emplace(a.record, stream);
    server.add_tier_tap(stream.tier, [&recorder](const TierFrameSet& f) { recorder.push(f); });
    spdlog::info("recording tier {} to {}", a.record_tier, a.record);
    // Never silently: every participant's viewer shows that the room is recorded, and by whom.
    if (s.hub) s.hub->start_recording("the OR server (volcast serve --record)");
  }
  // The stream on a NATS cluster: one more consumer of each published tier's encoding.
  if (!s.nats) return;
  s.publisher.emplace(*s.nats, a.nats_site, protocol::Welcome{s.cameras, wall_clock_us()});
  for (const std::string& t : a.nats_tiers) {
    const Tier tier = parse_tier(t, "--nats-tier", TierRate::kEveryFrameSet);
    s.publisher->publish_tier(server, tier);
    spdlog::info("offering tier {} on NATS as {} (encoded and published while a relay wants it)",
                 to_string(tier), cluster::tier_subject(a.nats_site, tier));
  }
  if (a.camera_only) return;
  // Participants of relays join this hub's sessions.
  try {
    s.bridge.emplace(*s.nats, a.nats_site, *s.hub);
    s.hub->attach_remote(&*s.bridge);
  } catch (const Error& e) {  // e.g. the account may not subscribe: the stream goes on
    spdlog::warn("viewers of relays cannot join the sessions: {}", e.what());
  }
  if (a.nats_state_replicas > 0) try {
      s.state.emplace(*s.nats, a.nats_site, *s.hub, a.nats_state_replicas);
      spdlog::info("sessions' state kept in NATS bucket {} ({} restored)",
                   cluster::session_state_bucket(a.nats_site), s.state->stats().restored);
    } catch (const Error& e) {
      spdlog::warn("sessions' state not kept on NATS: {}", e.what());
    }
}

// Starts the cameras and prints where to join: the join link (and --link-file), the browser link.
void start_serving(const ServeArgs& a, const ServerConfig& config, Serving& s) {
  Server& server = *s.server;
  if (s.replay)
    s.replay->start(server, &*s.hub);  // the recorded voices speak in the sessions
  else
    s.site->start(server);
  spdlog::info("serving {} camera(s) at {:.1f} fps on {}:{} ({}; Ctrl-C stops)", s.cameras.size(),
               s.replay ? s.replay->fps() : s.site->fps(), a.bind, server.port(),
               a.insecure ? "plain TCP, loopback only" : "TLS 1.3");
  if (!a.camera_only)
    spdlog::info("tiers may use {:.1f} CPU cores to encode (--tier-cpu-budget)",
                 server.tier_cpu_budget());
  if (a.camera_only)
    std::printf(
        "capture node: %zu camera(s) published on NATS as site '%s' (a site server adds "
        "them with --nats-cameras %s)\n",
        s.cameras.size(), a.nats_site.c_str(), a.nats_site.c_str());
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
}

// The line logged every 5 s: frame sets, viewers, failed cameras, recording and NATS figures.
void log_progress(const Serving& s) {
  int connected = 0;
  for (const auto& v : s.server->viewers()) connected += v.connected;
  std::string failed;  // cameras that cannot be read now
  const auto status = s.site ? s.site->camera_status() : std::vector<CameraStatus>{};
  for (size_t i = 0; i < status.size(); ++i)
    if (status[i].failed) failed += fmt::format("{}{}", failed.empty() ? "" : ", ", i);
  std::string recording;
  if (s.recorder) {
    const RecorderStats r = s.recorder->stats();
    recording = fmt::format("; recorded {} frame sets, {:.1f} MB{}{}", r.frame_sets,
                            static_cast<double>(r.bytes) / 1e6,
                            r.dropped ? fmt::format(", {} dropped", r.dropped) : "",
                            r.error.empty() ? "" : " -- STOPPED: " + r.error);
  }
  if (s.publisher) {
    const cluster::PublisherStats p = s.publisher->stats();
    recording += fmt::format("; NATS {} frame sets, {:.1f} MB{}", p.frame_sets,
                             static_cast<double>(p.bytes) / 1e6,
                             p.errors ? fmt::format(", {} lost ({})", p.errors, p.last_error) : "");
  }
  spdlog::info(
      "{} frame sets published, {} viewer(s) connected{}{}",
      s.replay ? s.replay->frame_sets_published() : s.site->frame_sets_published(), connected,
      failed.empty() ? "" : "; FAILED camera(s) " + failed + " (last good frame)", recording);
}

// Stops everything in the order that loses nothing, then logs the sessions' and viewers' figures.
void stop_serving(Serving& s) {
  // The sessions' last state is written while they are as the participants left them: stopping
  // the server ends every participant's session, which would delete their states.
  s.state.reset();
  s.listening = nullptr;
  if (s.voice) {
    s.voice->stop();
    for (const auto& h : s.voice->stats().heard)
      spdlog::info(
          "the OR heard participant {}: {} packets, mouth-to-ear p50 {:.0f} ms, p99 {:.0f} "
          "ms, {:.1f} % concealed",
          h.id, h.stream.packets, h.latency_ms_p50, h.latency_ms_p99, h.stream.concealed_percent());
  }
  if (s.site) s.site->stop();
  if (s.replay) {
    s.replay->stop();
    if (!s.replay->voices().cues.empty())
      spdlog::info("replay: {} recorded voice packets sent{}", s.replay->voices_sent(),
                   s.replay->voices_skipped() ? fmt::format(", {} skipped (unreadable records)",
                                                            s.replay->voices_skipped())
                                              : "");
  }
  if (s.recorder && s.hub) s.hub->stop_recording();  // told before the connections close
  s.server->stop();
  if (s.recorder) {
    s.recorder->stop();
    const RecorderStats r = s.recorder->stats();
    std::printf("recorded %llu frame sets, %.1f MB, to %s%s\n",
                static_cast<unsigned long long>(r.frame_sets), static_cast<double>(r.bytes) / 1e6,
                s.recorder->path().c_str(), r.error.empty() ? "" : (" -- " + r.error).c_str());
  }
  s.hub->attach(nullptr);
  s.hub->attach_remote(nullptr);
  s.bridge.reset();
  const SessionHubStats hs = s.hub->stats();
  spdlog::info(
      "sessions: {} joins, {} left, {} timed out, {} dropped; {} poses in, {} out; {} "
      "avatar frames in, {} out ({:.1f} MB)",
      hs.joins, hs.leaves, hs.timeouts, hs.dropped, hs.poses_in, hs.pose_messages_out,
      hs.avatar_frames_in, hs.avatar_frames_out, double(hs.avatar_bytes_out) / 1e6);
  for (const auto& v : s.server->viewers())
    spdlog::info(
        "viewer {} ({}{}): {} frame sets sent, {} skipped ({} over the latency budget), "
        "{:.1f} MB, path RTT {:.1f} ms, {:.1f} Mbit/s, {} tier switches",
        v.peer, to_string(v.tier), v.adaptive ? ", adaptive" : "", v.frames_sent, v.frames_dropped,
        v.frames_stale, static_cast<double>(v.bytes_sent) / 1e6, v.min_rtt_ms, v.bottleneck_mbit_s,
        v.switches.size());
}

}  // namespace

int run_serve(const ServeArgs& a) {
  Serving s;
  s.low_latency = hold_low_latency(a.low_latency);
  open_cameras(a, s);
  const ServerConfig config = server_config(a);
  open_server(a, config, s);
  add_outlets(a, s);
  start_serving(a, config, s);
  const auto start = std::chrono::steady_clock::now();
  auto last_report = start;
  while (!g_interrupted) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    const auto now = std::chrono::steady_clock::now();
    if (a.seconds > 0 && now - start > std::chrono::duration<double>(a.seconds)) break;
    if (s.replay && s.replay->finished()) {
      spdlog::info("the recording has played to its end (--no-loop)");
      break;
    }
    if (now - last_report > std::chrono::seconds(5)) {
      last_report = now;
      log_progress(s);
    }
  }
  stop_serving(s);
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
