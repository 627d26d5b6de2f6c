// What a Participant receives from the server (participant.hpp): each session message a step
// that updates the state snapshot() reads.
#include "participant_impl.hpp"

namespace volcast {
namespace {

// Whether two monitor states show the same (who set them aside).
bool same_view(const MonitorState& a, const MonitorState& b) {
  return a.generation == b.generation && a.slice == b.slice && a.center == b.center &&
         a.width == b.width && a.overlay == b.overlay;
}

}  // namespace

void Participant::Impl::handle_case(std::span<const uint8_t> p) {
  auto c = std::make_shared<SharedCase>(session::parse_case(p));
  std::lock_guard lock(mutex);
  objects.assign(c->objects.size(), Track{});
  for (size_t i = 0; i < c->objects.size(); ++i) {
    objects[i].newest.generation = c->generation;
    objects[i].newest.object = static_cast<uint16_t>(i);
    objects[i].newest.pose = objects[i].own = c->objects[i].rest;
  }
  monitor.reset();
  monitor_sent.reset();
  spdlog::info("session: case '{}' received: {} objects{}", printable(c->name), c->objects.size(),
               c->monitor ? ", a CT series" : "");
  shared_case = std::move(c);
}

void Participant::Impl::handle_voice(std::span<const uint8_t> p) {
  const auto [from, payload] = session::split_forwarded(p);
  const session::VoicePacketView packet = session::parse_voice(payload);
  {
    std::lock_guard lock(mutex);
    const auto it = remotes.find(from);
    if (it == remotes.end()) return;  // left meanwhile
    ++it->second->info.voice_packets;
    it->second->info.last_voice_us = wall_clock_us();
  }
  std::lock_guard lock(voice_mutex);
  if (voice_handler) voice_handler(from, packet);
}

void Participant::Impl::handle_drawing(Type type, std::span<const uint8_t> p) {
  if (type == Type::kAnnotation) {
    session::Annotation a = session::parse_annotation(p);
    std::lock_guard lock(mutex);
    annotations[a.id] = std::move(a);
  } else {
    const uint32_t id = session::parse_erased(p).first;
    std::lock_guard lock(mutex);
    annotations.erase(id);
  }
  std::lock_guard lock(voice_mutex);
  if (drawing_handler) drawing_handler(static_cast<uint8_t>(type), p);
}

void Participant::Impl::handle(uint8_t type, std::span<const uint8_t> p) {
  if (static_cast<Type>(type) == Type::kCase) return handle_case(p);
  if (static_cast<Type>(type) == Type::kVoiceFrom) return handle_voice(p);
  if (static_cast<Type>(type) == Type::kAnnotation || static_cast<Type>(type) == Type::kErased)
    return handle_drawing(static_cast<Type>(type), p);
  const int64_t now_server = server_now();
  std::lock_guard lock(mutex);
  switch (static_cast<Type>(type)) {
    case Type::kSessionList:
      state.lobby = session::parse_session_list(p);
      return;
    case Type::kJoined:
      return on_joined(session::parse_joined(p));
    case Type::kSessionError:
      state.last_error = session::parse_error(p);
      monitor_sent.reset();  // perhaps about it: the server's state shows again
      spdlog::warn("session: the server says: {}", printable(state.last_error, 300));
      return;
    case Type::kParticipantJoined:
      return on_participant_joined(session::parse_participant(p));
    case Type::kParticipantLeft: {
      const auto [id, why] = session::parse_left(p);
      return on_left(id, why);
    }
    case Type::kPoseFrom:
      return on_pose(p, now_server);
    case Type::kPoseEchoFrom: {
      const auto [from, sequence] = session::parse_echo(p);
      const auto it = pose_sent_us.find(sequence);
      if (it != pose_sent_us.end())
        add_sample(round_trips_ms, double(steady_us() - it->second) / 1000.0);
      return;
    }
    case Type::kTeleported:
      return on_teleported(session::parse_teleported(p));
    case Type::kAvatarCameraFrom:
      return on_avatar_camera(p);
    case Type::kAvatarFrameFrom:
      return on_avatar_frame(p, now_server);
    case Type::kCase:
      return;  // parsed before the lock (handle_case)
    case Type::kObjectState:
      return on_object_state(session::parse_object_state(p));
    case Type::kMonitorState: {
      const MonitorState m = session::parse_monitor_state(p);
      if (!shared_case || m.generation != shared_case->generation) return;
      monitor = m;
      if (monitor_sent && same_view(monitor_sent->first, m)) monitor_sent.reset();  // it arrived
      return;
    }
    case Type::kVoiceStateFrom: {
      const auto [from, payload] = session::split_forwarded(p);
      const bool muted = session::parse_voice_state(payload);
      if (const auto it = remotes.find(from); it != remotes.end()) it->second->info.muted = muted;
      return;
    }
    case Type::kPointerFrom:
      return on_pointer(p, now_server);
    case Type::kAnnotation:
    case Type::kErased:
      return;  // handled before the lock (handle_drawing)
    default:
      throw Error("the server sent session message type " + std::to_string(type) +
                  ", which a participant does not take");
  }
}

void Participant::Impl::on_joined(const session::Joined& j) {
  state.joined = true;
  state.id = j.participant;
  state.session_name = j.session_name;
  state.spot = j.spot;
  state.room_from_site.rotation =
      Eigen::AngleAxisd(j.site_yaw, Eigen::Vector3d::UnitY()).toRotationMatrix();
  state.room_from_site.translation = j.site_translation.cast<double>();
  state.last_error.clear();
  spdlog::info("session: joined '{}' as participant {}", printable(j.session_name), j.participant);
  if (config.camera) {
    session::AvatarCamera cam{config.camera->calibration, config.camera->depth_codec,
                              config.camera->color_codec};
    post(Type::kAvatarCamera, session::serialize(cam));
  }
}

void Participant::Impl::on_participant_joined(const session::ParticipantInfo& info) {
  if (info.id == state.id) return;
  auto r = std::make_shared<Remote>();
  r->info.id = info.id;
  r->info.name = info.name;
  r->info.role = info.role;
  r->info.has_camera = info.has_camera;
  r->info.spot = info.spot;
  remotes[info.id] = r;
}

void Participant::Impl::on_left(uint32_t id, session::LeftReason why) {
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

void Participant::Impl::on_pose(std::span<const uint8_t> p, int64_t now_server) {
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

void Participant::Impl::on_teleported(const session::Teleported& t) {
  if (t.participant == state.id) state.spot = t.to;
  if (const auto it = remotes.find(t.participant); it != remotes.end())
    it->second->info.spot = t.to;
  state.teleports.push_back({t.participant, t.from, t.to, t.time_us});
  if (state.teleports.size() > 16) state.teleports.erase(state.teleports.begin());
}

void Participant::Impl::on_avatar_camera(std::span<const uint8_t> p) {
  const auto [id, rest] = session::split_forwarded(p);
  session::AvatarCamera cam = session::parse_avatar_camera(rest);
  const auto it = remotes.find(id);
  if (it == remotes.end()) return;
  std::lock_guard decode_lock(decode_mutex);
  Remote& r = *it->second;
  r.depth_decoder = make_depth_decoder(cam.depth_codec);
  r.color_decoder = make_color_decoder(cam.color_codec);
  r.info.has_camera = true;
  r.camera = std::move(cam);
  r.decoded_sequence = 0;
  r.decoded.reset();
}

void Participant::Impl::on_avatar_frame(std::span<const uint8_t> p, int64_t now_server) {
  const auto [id, rest] = session::split_forwarded(p);
  const auto it = remotes.find(id);
  if (it == remotes.end() || !it->second->camera) return;
  Remote& r = *it->second;
  const session::AvatarFrameView f = session::parse_avatar_frame(rest, r.camera->calibration);
  if (f.sequence <= r.info.avatar_sequence) return;
  r.info.avatar_sequence = f.sequence;
  r.avatar_payload = std::make_shared<const std::vector<uint8_t>>(rest.begin(), rest.end());
  const int64_t rx = wall_clock_us();
  if (r.avatars_received++ == 0) r.first_avatar_rx_us = rx;
  r.last_avatar_rx_us = rx;
  add_sample(r.avatar_latencies_ms, double(now_server - f.capture_us) / 1000.0);
}

void Participant::Impl::on_pointer(std::span<const uint8_t> p, int64_t now_server) {
  const auto [id, rest] = session::split_forwarded(p);
  const session::PointerMessage m = session::parse_pointer(rest);
  const auto remote = remotes.find(id);
  if (remote == remotes.end()) return;  // left meanwhile
  ++remote->second->pointers_received;
  add_sample(remote->second->pointer_ages_ms, double(now_server - m.time_us) / 1000.0);
  if (const auto it = pointer_in.find(id);
      it != pointer_in.end() && m.sequence <= it->second.sequence)
    return;  // older
  pointer_in[id] = m;
  if (m.on)
    pointers[id] = PointerView{id, m.origin, m.has_hit, m.hit, m.time_us};
  else
    pointers.erase(id);
}

void Participant::Impl::on_object_state(const session::ObjectState& o) {
  if (!shared_case || o.generation != shared_case->generation || o.object >= objects.size())
    return;  // about another case
  Track& t = objects[o.object];
  if (o.sequence < t.newest.sequence) return;  // older
  if (o.owner == state.id && t.newest.owner == state.id) {
    t.newest.sequence = o.sequence;  // our own hold confirmed again: keep our pose
    return;
  }
  if (o.owner == state.id) t.own = t.newest.pose;  // just granted: starts where it is
  t.newest = o;
  t.poses.emplace_back(o.time_us, o.pose);
  if (t.poses.size() > kPoseHistory) t.poses.pop_front();
}

}  // namespace volcast
