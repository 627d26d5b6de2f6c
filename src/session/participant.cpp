#include "volcast/session/participant.hpp"

#include "participant_impl.hpp"
#include "volcast/session/names.hpp"

namespace volcast {

Participant::Participant(Client& client, ParticipantConfig config)
    : impl_(std::make_unique<Impl>(client, std::move(config))) {
  Impl& m = *impl_;
  {
    // The same checks the server makes, before anything is sent.
    session::Join j;
    j.session = m.config.session;
    j.name = m.config.name;
    session::parse_join(session::serialize(j));
    m.config.session = session::checked_name(m.config.session, "session name");
    m.config.name = session::checked_name(m.config.name, "display name");
  }
  if (m.config.camera) {
    session::parse_avatar_camera(session::serialize(session::AvatarCamera{
        m.config.camera->calibration, m.config.camera->depth_codec, m.config.camera->color_codec}));
    m.depth_encoder = make_depth_encoder(m.config.camera->depth_codec);
    m.color_encoder = make_color_encoder(m.config.camera->color_codec);
  }
  if (m.config.echo_every < 1) throw Error("session: echo_every must be at least 1");
  m.offset_us = client.clock_offset_us();
  Impl* impl = impl_.get();
  client.set_session_handler(
      [impl](uint8_t type, std::span<const uint8_t> p) { impl->handle(type, p); },
      [](uint8_t type) { return type >= 0x40 ? session::max_payload(type) : 0u; });
  m.post(Type::kListSessions, {});
  m.send_join(m.config.session, m.config.create);
}

Participant::~Participant() = default;

void Participant::detach() {
  Impl& m = *impl_;
  Client* client = nullptr;
  {
    std::lock_guard lock(m.client_mutex);
    if (m.detached) return;
    m.detached = true;
    client = m.client;
  }
  // Outside client_mutex: the handler may be running, and posting (which takes it).
  client->set_session_handler(nullptr, nullptr);
}

void Participant::reattach(Client& client) {
  Impl& m = *impl_;
  std::string session;
  {
    std::lock_guard lock(m.mutex);
    session = m.state.session_name.empty() ? m.config.session : m.state.session_name;
    m.state.joined = false;  // until the server answers the new Join
    m.remotes.clear();       // the server sends those still there again, and the drawing
    m.pointers.clear();
    m.pointer_in.clear();
    m.annotations.clear();
  }
  Client* old = nullptr;
  {
    std::lock_guard lock(m.client_mutex);
    if (!m.detached) old = m.client;
    m.client = &client;
    m.detached = false;
    m.offset_us = client.clock_offset_us();
  }
  // Outside client_mutex: the old handler may be running, and posting (which takes it).
  if (old) old->set_session_handler(nullptr, nullptr);
  Impl* impl = impl_.get();
  client.set_session_handler(
      [impl](uint8_t type, std::span<const uint8_t> p) { impl->handle(type, p); },
      [](uint8_t type) { return type >= 0x40 ? session::max_payload(type) : 0u; });
  m.send_join(session, m.config.create);
}

void Participant::send_voice(const session::VoicePacketView& packet) {
  Impl& m = *impl_;
  if (!joined()) return;
  ++m.voice_sent;
  m.post(Type::kVoice, session::serialize(packet), voice_key());
}

void Participant::set_muted(bool muted) {
  impl_->post(Type::kVoiceState, session::serialize_voice_state(muted));
}

void Participant::set_voice_handler(VoiceHandler handler) {
  std::lock_guard lock(impl_->voice_mutex);
  impl_->voice_handler = std::move(handler);
}

void Participant::set_drawing_handler(DrawingHandler handler) {
  std::lock_guard lock(impl_->voice_mutex);
  impl_->drawing_handler = std::move(handler);
}

void Participant::publish(const BodyPose& playarea_pose) {
  Impl& m = *impl_;
  session::PoseMessage msg;
  {
    std::lock_guard lock(m.mutex);
    if (!m.state.joined) return;
    // Over the server's rate (rate_limit.hpp) it would drop the pose: skipped here instead.
    if (!m.pose_pace.admit(0, static_cast<uint8_t>(Type::kPose), steady_us()).admitted) return;
    msg.sequence = ++m.pose_sequence;
    msg.echo_wanted = msg.sequence % static_cast<uint32_t>(m.config.echo_every) == 0;
    msg.body = to_room(session::room_from_playarea(m.state.spot), playarea_pose);
    m.state.own_body = msg.body;
    m.state.has_own_body = true;
    if (msg.echo_wanted) {
      m.pose_sent_us[msg.sequence] = steady_us();
      while (m.pose_sent_us.size() > 256) m.pose_sent_us.erase(m.pose_sent_us.begin());
    }
    ++m.poses_sent;
  }
  msg.time_us = m.server_now();
  m.post(Type::kPose, session::serialize(msg), pose_key());
}

void Participant::point(bool on, const Eigen::Vector3f& origin, bool has_hit,
                        const Eigen::Vector3f& hit) {
  Impl& m = *impl_;
  session::PointerMessage msg{0, 0, on, origin, has_hit, hit};
  if (!origin.allFinite() || !hit.allFinite()) throw Error("session: a pointer is not finite");
  {
    std::lock_guard lock(m.mutex);
    if (!m.state.joined) return;
    const bool was_on = m.pointers.contains(m.state.id);
    if (!on && !was_on) return;  // put away already
    // Over the server's rate it would drop it: skipped here instead (never the last, "off").
    if (on && !m.pose_pace.admit(0, static_cast<uint8_t>(Type::kPointer), steady_us()).admitted)
      return;
    msg.sequence = ++m.pointer_sequence;
    msg.time_us = m.server_now();
    if (on)
      m.pointers[m.state.id] = PointerView{m.state.id, origin, has_hit, hit, msg.time_us};
    else
      m.pointers.erase(m.state.id);
  }
  m.post(Type::kPointer, session::serialize(msg), pointer_key());
}

uint32_t Participant::annotate(session::Annotation a) {
  Impl& m = *impl_;
  if (a.kind == session::AnnotationKind::kLabel) a.text = session::check_label_text(a.text);
  {
    std::lock_guard lock(m.mutex);
    if (!m.state.joined) return 0;
    a.tag = ++m.annotation_tag;
    a.generation = 0;
    if (a.anchor == session::AnnotationAnchor::kMonitor) {
      if (!m.shared_case || !m.shared_case->monitor)
        throw Error("session: an annotation on the monitor, but the case has no CT series");
      a.generation = m.shared_case->generation;
    }
  }
  std::vector<uint8_t> payload = session::serialize_annotate(a);
  session::parse_annotate(payload);  // what the server would drop this participant for
  m.post(Type::kAnnotate, payload);
  return a.tag;
}

void Participant::erase(uint32_t id) {
  impl_->post(Type::kErase, session::serialize_erase(id));
}

void Participant::teleport(const session::Spot& to) {
  impl_->post(Type::kTeleport, session::serialize(to));
}

void Participant::upload(std::shared_ptr<const CameraFrame> shared, int64_t capture_us) {
  Impl& m = *impl_;
  if (!shared) throw Error("session: no avatar frame to upload");
  const CameraFrame& frame = *shared;
  if (!m.config.camera) throw Error("session: this participant has no camera to upload");
  const Intrinsics& k = m.config.camera->calibration.depth;
  if (frame.depth.width != k.width || frame.depth.height != k.height)
    throw Error("session: avatar depth frame is " + std::to_string(frame.depth.width) + "x" +
                std::to_string(frame.depth.height) + ", its camera " + std::to_string(k.width) +
                "x" + std::to_string(k.height));
  std::lock_guard upload_lock(m.upload_mutex);
  {
    std::lock_guard lock(m.mutex);
    if (!m.state.joined) return;
  }
  m.depth_encoder->encode(frame.depth, true, m.depth_bytes);
  m.color_bytes.clear();
  if (!frame.color.empty()) m.color_encoder->encode(frame.color, true, m.color_bytes);
  uint64_t sequence;
  {
    std::lock_guard lock(m.mutex);
    sequence = ++m.avatar_sequence;
    ++m.avatar_frames_sent;
    m.own = std::move(shared);
  }
  m.post(Type::kAvatarFrame,
         session::serialize_avatar_frame(sequence, capture_us + m.offset_us, m.depth_bytes,
                                         m.color_bytes),
         avatar_key());
}

void Participant::heartbeat() {
  impl_->post(Type::kHeartbeat, {});
}

void Participant::list_sessions() {
  impl_->post(Type::kListSessions, {});
}

void Participant::leave() {
  Impl& m = *impl_;
  {
    std::lock_guard lock(m.mutex);
    m.state.joined = false;
    m.remotes.clear();
    m.pointers.clear();  // the next session's come with it
    m.pointer_in.clear();
    m.annotations.clear();
  }
  m.post(Type::kLeave, {});
}

void Participant::join(const std::string& session, bool create) {
  impl_->send_join(session, create);
}

bool Participant::joined() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->state.joined;
}

SessionSnapshot Participant::snapshot(int64_t now_us) const {
  const Impl& m = *impl_;
  const int64_t at = now_us + m.offset_us - m.config.interpolation_delay_us;
  std::lock_guard lock(m.mutex);
  SessionSnapshot s = m.state;
  for (const auto& [id, r] : m.remotes) {
    RemoteParticipant p = r->info;
    if (!r->poses.empty()) p.pose = pose_at(r->poses, at);
    if (r->camera) {
      CameraCalibration c = r->camera->calibration;
      c.world_from_camera = session::room_from_playarea(p.spot) * c.world_from_camera;
      p.avatar_camera = c;
    }
    s.others.push_back(std::move(p));
  }
  if (m.shared_case) {
    s.case_generation = m.shared_case->generation;
    for (const Impl::Track& t : m.objects) {
      ObjectView v{t.newest.object, t.newest.owner, t.newest.pose, t.newest.sequence};
      if (t.newest.owner != 0 && t.newest.owner == m.state.id)
        v.pose = t.own;
      else if (t.newest.owner != 0 && !t.poses.empty())
        v.pose = pose_at(t.poses, at);
      s.objects.push_back(v);
    }
    s.monitor = m.monitor;
    if (m.monitor_sent && steady_us() - m.monitor_sent->second < Impl::kMonitorWaitUs)
      s.monitor = m.monitor_sent->first;  // its own change, on its way
  }
  for (const auto& [id, v] : m.pointers) s.pointers.push_back(v);
  s.annotations.reserve(m.annotations.size());
  for (const auto& [id, a] : m.annotations) s.annotations.push_back(a);
  return s;
}

void Participant::voice_scene(int64_t now_us, VoiceScene& out) const {
  const Impl& m = *impl_;
  const int64_t at = now_us + m.offset_us - m.config.interpolation_delay_us;
  std::lock_guard lock(m.mutex);
  out.spot = m.state.spot;
  out.has_own_body = m.state.has_own_body;
  out.own_head = m.state.own_body.head;
  out.others.resize(m.remotes.size());
  size_t i = 0;
  for (const auto& [id, r] : m.remotes) {
    VoiceScene::Speaker& o = out.others[i++];
    o.id = id;
    o.name.assign(r->info.name);
    o.spot = r->info.spot;
    o.has_pose = !r->poses.empty();
    if (o.has_pose) o.head = pose_at(r->poses, at).head;
  }
}

std::shared_ptr<const SharedCase> Participant::shared_case() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->shared_case;
}

void Participant::grab(uint16_t object) {
  Impl& m = *impl_;
  session::ObjectRequest q;
  {
    std::lock_guard lock(m.mutex);
    if (!m.shared_case || object >= m.objects.size()) return;
    q.generation = m.shared_case->generation;
  }
  q.object = object;
  m.post(Type::kGrab, session::serialize(q, false));
}

void Participant::move_object(uint16_t object, const Pose& room_from_object) {
  impl_->post_object(Type::kObjectMove, object, room_from_object);
}

void Participant::release(uint16_t object, const Pose& room_from_object) {
  // Coalesced with any queued move of it: the release replaces it and is never overtaken.
  impl_->post_object(Type::kRelease, object, room_from_object);
}

bool Participant::object_request_queued(uint16_t object) const {
  std::lock_guard lock(impl_->client_mutex);
  return !impl_->detached && impl_->client->session_queued(Impl::object_key(object));
}

void Participant::set_monitor(const MonitorState& state) {
  Impl& m = *impl_;
  MonitorState s = state;
  {
    std::lock_guard lock(m.mutex);
    if (!m.shared_case) return;
    s.generation = m.shared_case->generation;
    s.by = m.state.id;
    m.monitor_sent = {s, steady_us()};
  }
  m.post(Type::kSetMonitor, session::serialize_set_monitor(s), uint64_t{4} << 32);
}

std::shared_ptr<const CameraFrame> Participant::avatar_frame(uint32_t id) {
  Impl& m = *impl_;
  std::shared_ptr<Impl::Remote> r;
  std::shared_ptr<const std::vector<uint8_t>> payload;
  uint64_t sequence = 0;
  {
    std::lock_guard lock(m.mutex);
    const auto it = m.remotes.find(id);
    if (it == m.remotes.end() || !it->second->camera) return nullptr;
    r = it->second;
    payload = r->avatar_payload;
    sequence = r->info.avatar_sequence;
  }
  std::lock_guard decode_lock(m.decode_mutex);
  if (!payload || !r->depth_decoder) return nullptr;
  if (r->decoded_sequence == sequence) return r->decoded;
  const session::AvatarFrameView f = session::parse_avatar_frame(*payload, r->camera->calibration);
  auto frame = std::make_shared<CameraFrame>();
  r->depth_decoder->decode(f.depth, frame->depth);
  if (!f.color.empty()) r->color_decoder->decode(f.color, frame->color);
  const Intrinsics& k = r->camera->calibration.depth;
  if (frame->depth.width != k.width || frame->depth.height != k.height ||
      (!frame->color.empty() && (frame->color.width != k.width || frame->color.height != k.height)))
    throw Error("session: participant " + std::to_string(id) +
                "'s avatar frame decodes to another size than its camera");
  frame->device_timestamp_us = f.capture_us;
  r->decoded = std::move(frame);
  r->decoded_sequence = sequence;
  return r->decoded;
}

std::optional<CameraCalibration> Participant::own_camera() const {
  const Impl& m = *impl_;
  if (!m.config.camera) return std::nullopt;
  std::lock_guard lock(m.mutex);
  CameraCalibration c = m.config.camera->calibration;
  c.world_from_camera = session::room_from_playarea(m.state.spot) * c.world_from_camera;
  return c;
}

std::shared_ptr<const CameraFrame> Participant::own_frame() const {
  std::lock_guard lock(impl_->mutex);
  return impl_->own;
}

ParticipantStats Participant::stats() const {
  const Impl& m = *impl_;
  std::lock_guard lock(m.mutex);
  ParticipantStats s;
  s.poses_sent = m.poses_sent;
  s.avatar_frames_sent = m.avatar_frames_sent;
  s.voice_sent = m.voice_sent;
  s.round_trip_samples = m.round_trips_ms.size();
  s.round_trip_ms_p50 = percentile(m.round_trips_ms, 0.5);
  s.round_trip_ms_p99 = percentile(m.round_trips_ms, 0.99);
  std::map<uint32_t, const Impl::Remote*> everyone;
  for (const auto& [id, r] : m.gone) everyone[id] = r.get();
  for (const auto& [id, r] : m.remotes) everyone[id] = r.get();
  for (const auto& [id, r] : everyone) {
    if (r->info.role == session::Role::kOrSite) continue;  // sends no poses: its cameras stream
    RemoteStats o;
    o.id = id;
    o.name = r->info.name;
    o.poses_received = r->poses_received;
    if (r->poses_received > 1 && r->last_pose_rx_us > r->first_pose_rx_us)
      o.pose_rate_hz =
          double(r->poses_received - 1) * 1e6 / double(r->last_pose_rx_us - r->first_pose_rx_us);
    o.pose_age_ms_p50 = percentile(r->pose_ages_ms, 0.5);
    o.pose_age_ms_p99 = percentile(r->pose_ages_ms, 0.99);
    o.avatar_frames_received = r->avatars_received;
    if (r->avatars_received > 1 && r->last_avatar_rx_us > r->first_avatar_rx_us)
      o.avatar_fps = double(r->avatars_received - 1) * 1e6 /
                     double(r->last_avatar_rx_us - r->first_avatar_rx_us);
    o.avatar_latency_ms_p50 = percentile(r->avatar_latencies_ms, 0.5);
    o.avatar_latency_ms_p99 = percentile(r->avatar_latencies_ms, 0.99);
    o.pointers_received = r->pointers_received;
    o.pointer_age_ms_p50 = percentile(r->pointer_ages_ms, 0.5);
    o.pointer_age_ms_p99 = percentile(r->pointer_ages_ms, 0.99);
    s.others.push_back(std::move(o));
  }
  return s;
}

int64_t Participant::clock_offset_us() const {
  return impl_->offset_us;
}

}  // namespace volcast
