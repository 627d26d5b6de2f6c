// What a Participant receives from the server (participant.hpp): each session message a step
// that updates the state snapshot() reads. The dispatch, and presence: the lobby, who is here,
// poses and teleports; the other features' steps are in participant_<feature>.cpp.
#include "participant_impl.hpp"

namespace volcast {

// Every feature's routes, listed once.
std::span<const session::FeatureRoutes<Participant::Impl::Route>> Participant::Impl::features() {
  using session::Feature;
  static const session::FeatureRoutes<Route> kFeatures[] = {{presence_routes(), Feature::kPresence},
                                                            {avatar_routes(), Feature::kAvatars},
                                                            {voice_routes(), Feature::kVoice},
                                                            {drawing_routes(), Feature::kDrawing},
                                                            {object_routes(), Feature::kObjects}};
  return kFeatures;
}

const Participant::Impl::Route* Participant::Impl::route(uint8_t type) {
  static const auto routes = session::index_routes(features());
  return routes[type];
}

std::vector<std::pair<session::Type, session::Feature>> Participant::handled_types() {
  return session::routed_types(Impl::features());
}

void Participant::Impl::handle(uint8_t type, Payload p) {
  const Route* r = route(type);
  if (!r)
    throw Error("the server sent session message type " + std::to_string(type) +
                ", which a participant does not take");
  const int64_t now_server = server_now();
  if (!r->locked) return (this->*r->handle)(p, now_server);
  std::lock_guard lock(mutex);
  (this->*r->handle)(p, now_server);
}

std::span<const Participant::Impl::Route> Participant::Impl::presence_routes() {
  static constexpr Route kRoutes[] = {
      {Type::kSessionList, &Impl::on_session_list},
      {Type::kJoined, &Impl::on_joined},
      {Type::kSessionError, &Impl::on_session_error},
      {Type::kParticipantJoined, &Impl::on_participant_joined},
      {Type::kParticipantLeft, &Impl::on_left},
      {Type::kPoseFrom, &Impl::on_pose},
      {Type::kPoseEchoFrom, &Impl::on_pose_echo},
      {Type::kTeleported, &Impl::on_teleported},
      {Type::kRecordingState, &Impl::on_recording_state},
  };
  return kRoutes;
}

void Participant::Impl::on_session_list(Payload p, int64_t) {
  state.lobby = session::parse_session_list(p);
}

void Participant::Impl::on_joined(Payload p, int64_t) {
  const session::Joined j = session::parse_joined(p);
  state.joined = true;
  state.id = j.participant;
  state.session_name = j.session_name;
  state.spot = j.spot;
  state.room_from_site.rotation =
      Eigen::AngleAxisd(j.site_yaw, Eigen::Vector3d::UnitY()).toRotationMatrix();
  state.room_from_site.translation = j.site_translation.cast<double>();
  state.last_error.clear();
  state.recording = {};  // the server's follows when one runs
  spdlog::info("session: joined '{}' as participant {}", printable(j.session_name), j.participant);
  if (config.camera) {
    session::AvatarCamera cam{config.camera->calibration, config.camera->depth_codec,
                              config.camera->color_codec};
    post(Type::kAvatarCamera, session::serialize(cam));
  }
}

void Participant::Impl::on_session_error(Payload p, int64_t) {
  state.last_error = session::parse_error(p);
  monitor_sent.reset();  // perhaps about it: the server's state shows again
  spdlog::warn("session: the server says: {}", printable(state.last_error, 300));
}

void Participant::Impl::on_participant_joined(Payload p, int64_t) {
  const session::ParticipantInfo info = session::parse_participant(p);
  if (info.id == state.id) return;
  auto r = std::make_shared<Remote>();
  r->info.id = info.id;
  r->info.name = info.name;
  r->info.role = info.role;
  r->info.has_camera = info.has_camera;
  r->info.spot = info.spot;
  remotes[info.id] = r;
}

void Participant::Impl::on_left(Payload p, int64_t) {
  const auto [id, why] = session::parse_left(p);
  if (const auto it = remotes.find(id); it != remotes.end()) {
    state.departed.emplace_back(id, it->second->info.name, why);
    if (state.departed.size() > 64) state.departed.erase(state.departed.begin());
    gone[id] = it->second;
    pointers.erase(id);
    pointer_in.erase(id);
    if (gone.size() > 64) gone.erase(gone.begin());
    remotes.erase(it);
  }
}

void Participant::Impl::on_pose(Payload p, int64_t now_server) {
  const auto [id, rest] = session::split_forwarded(p);
  const session::PoseMessage m = session::parse_pose(rest);
  const auto it = remotes.find(id);
  if (it == remotes.end()) return;
  Remote& r = *it->second;
  if (r.info.has_pose && m.sequence <= r.info.newest_pose_sequence) return;  // older
  r.info.has_pose = true;
  r.info.newest_pose = m.body;
  r.info.newest_pose_time_us = m.time_us;
  r.info.newest_pose_sequence = m.sequence;
  r.poses.emplace_back(m.time_us, m.body);
  if (r.poses.size() > kPoseHistory) r.poses.pop_front();
  const int64_t rx = wall_clock_us();
  if (r.poses_received++ == 0) r.first_pose_rx_us = rx;
  r.last_pose_rx_us = rx;
  add_sample(r.pose_ages_ms, double(now_server - m.time_us) / 1000.0);
  if (m.echo_wanted) post(Type::kPoseEcho, session::serialize_echo(id, m.sequence));
}

void Participant::Impl::on_pose_echo(Payload p, int64_t) {
  const auto [from, sequence] = session::parse_echo(p);
  const auto it = pose_sent_us.find(sequence);
  if (it != pose_sent_us.end())
    add_sample(round_trips_ms, double(steady_us() - it->second) / 1000.0);
}

void Participant::Impl::on_teleported(Payload p, int64_t) {
  const session::Teleported t = session::parse_teleported(p);
  if (t.participant == state.id) state.spot = t.to;
  if (const auto it = remotes.find(t.participant); it != remotes.end())
    it->second->info.spot = t.to;
  state.teleports.push_back({t.participant, t.from, t.to, t.time_us});
  if (state.teleports.size() > 16) state.teleports.erase(state.teleports.begin());
}

void Participant::Impl::on_recording_state(Payload p, int64_t) {
  state.recording = session::parse_recording_state(p);
  if (state.recording.recording)
    spdlog::warn("session: this room is being recorded, by {}", printable(state.recording.by));
  else
    spdlog::info("session: the recording stopped");
}

}  // namespace volcast
