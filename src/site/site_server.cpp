// A site's server as a whole (site_server.hpp): the sessions, the OR's voice, the case, the
// server, the recorder and the NATS outlets, started and stopped in order; the cameras are in
// site_cameras.cpp.
#include "volcast/site/site_server.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "site_parts.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"

namespace volcast {
namespace {

using detail::SiteParts;

// The virtual OR's sessions (and the case shown in them), then the server that serves them.
void open_server(SiteParts& s) {
  const SiteServerOptions& a = s.options;
  ServerConfig config = a.server;
  SessionHubConfig hub_config = a.hub;
  if (!a.mic.empty() || !a.speaker.empty())
    hub_config.site_listener = [&s](uint32_t id, const session::VoicePacketView& p) {
      if (voice::SiteVoice* v = s.listening.load()) v->put(id, p);
    };
  SessionHub& hub = s.hub.emplace(hub_config);
  for (const auto& name : a.sessions) hub.create_session(name);
  if (!a.mic.empty() || !a.speaker.empty()) {
    voice::SiteVoiceConfig v;
    v.echo_cancellation = a.echo_cancellation;
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
void add_outlets(SiteParts& s) {
  const SiteServerOptions& a = s.options;
  Server& server = *s.server;
  if (!a.record_path.empty()) {
    RecordingStream stream;
    stream.tier = a.record_tier;
    stream.started_us = wall_clock_us();
    stream.origin = "volcast serve --record";
    stream.welcome = {s.cameras, wall_clock_us()};
    BackgroundRecorder& recorder = s.recorder.emplace(a.record_path, stream);
    server.add_tier_tap(stream.tier, [&recorder](const TierFrameSet& f) { recorder.push(f); });
    spdlog::info("recording tier {} to {}", to_string(a.record_tier), a.record_path);
    // Never silently: every participant's viewer shows that the room is recorded, and by whom.
    if (s.hub) s.hub->start_recording("the OR server (volcast serve --record)");
  }
  // The stream on a NATS cluster: one more consumer of each published tier's encoding.
  if (!s.nats) return;
  s.publisher.emplace(*s.nats, a.nats_site, protocol::Welcome{s.cameras, wall_clock_us()});
  for (const Tier& tier : a.nats_tiers) {
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

}  // namespace

std::string SiteServer::progress() const {
  const detail::SiteParts& s = *parts_;
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
  return fmt::format(
      "{} frame sets published, {} viewer(s) connected{}{}",
      s.replay ? s.replay->frame_sets_published() : s.site->frame_sets_published(), connected,
      failed.empty() ? "" : "; FAILED camera(s) " + failed + " (last good frame)", recording);
}

void SiteServer::stop() {
  detail::SiteParts& s = *parts_;
  if (s.stopped) return;
  s.stopped = true;
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

SiteServer::SiteServer(SiteServerOptions options) : parts_(std::make_unique<detail::SiteParts>()) {
  parts_->options = std::move(options);
  detail::open_cameras(*parts_);
  open_server(*parts_);
  add_outlets(*parts_);
}

SiteServer::~SiteServer() {
  try {
    stop();
  } catch (const std::exception& e) {
    spdlog::error("stopping the site: {}", e.what());
  }
}

void SiteServer::start() {
  detail::SiteParts& s = *parts_;
  if (s.replay)
    s.replay->start(*s.server, &*s.hub);  // the recorded voices speak in the sessions
  else
    s.site->start(*s.server);
}

Server& SiteServer::server() {
  return *parts_->server;
}

SessionHub& SiteServer::hub() {
  return *parts_->hub;
}

const std::vector<protocol::CameraInfo>& SiteServer::cameras() const {
  return parts_->cameras;
}

double SiteServer::fps() const {
  return parts_->replay ? parts_->replay->fps() : parts_->site->fps();
}

bool SiteServer::replaying() const {
  return parts_->replay.has_value();
}

bool SiteServer::finished() const {
  return parts_->replay && parts_->replay->finished();
}

}  // namespace volcast
