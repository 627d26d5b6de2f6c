#include "volcast/session/participant.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <deque>
#include <map>

#include "volcast/codec/color_codec.hpp"
#include "volcast/codec/depth_codec.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/text.hpp"
#include "volcast/session/names.hpp"
#include "volcast/session/rate_limit.hpp"

namespace volcast {

using session::Type;

namespace {

constexpr size_t kPoseHistory = 32;
constexpr size_t kMaxSamples = 1 << 16;

uint64_t pose_key() {
  return 1;
}
uint64_t avatar_key() {
  return 2;
}

int64_t steady_us() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(p * double(v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

void add_sample(std::vector<double>& v, double x) {
  if (v.size() < kMaxSamples) v.push_back(x);
}

BodyPose to_room(const RigidTransform& room_from_playarea, const BodyPose& b) {
  const Eigen::Matrix3f r = room_from_playarea.rotation.cast<float>();
  const Eigen::Vector3f t = room_from_playarea.translation.cast<float>();
  const Eigen::Quaternionf q(r);
  const auto one = [&](const Pose& p) {
    return Pose{r * p.position + t, (q * p.orientation).normalized()};
  };
  return {one(b.head), one(b.left_hand), one(b.right_hand), b.hands_tracked};
}

// The pose at `at` (server clock) from time-stamped poses, oldest first: interpolated between
// the two around it; before the first or after the newest, that one (no guessing).
template <typename T>
T pose_at(const std::deque<std::pair<int64_t, T>>& q, int64_t at) {
  T p = q.back().second;
  if (at <= q.front().first) p = q.front().second;
  for (size_t i = 1; i < q.size(); ++i)
    if (q[i - 1].first <= at && at < q[i].first) {
      const float t = float(at - q[i - 1].first) / float(q[i].first - q[i - 1].first);
      return interpolate(q[i - 1].second, q[i].second, t);
    }
  return p;
}

}  // namespace

struct Participant::Impl {
  Client& client;
  ParticipantConfig config;
  int64_t offset_us = 0;
  std::unique_ptr<DepthEncoder> depth_encoder;
  std::unique_ptr<ColorEncoder> color_encoder;
  std::vector<uint8_t> depth_bytes, color_bytes;
  std::mutex upload_mutex;  // the encoders and their buffers

  mutable std::mutex mutex;  // everything below
  SessionSnapshot state;
  uint32_t pose_sequence = 0;
  session::RateLimiter pose_pace;  // the server's pose limit, kept here (a faster display)
  uint64_t avatar_sequence = 0;
  std::map<uint32_t, int64_t> pose_sent_us;  // sequence -> local steady time, echoes pending
  std::vector<double> round_trips_ms;
  uint64_t poses_sent = 0, avatar_frames_sent = 0;
  std::shared_ptr<const CameraFrame> own;

  struct Remote {
    RemoteParticipant info;
    std::deque<std::pair<int64_t, BodyPose>> poses;  // (server time, room pose), oldest first
    int64_t first_pose_rx_us = 0, last_pose_rx_us = 0;
    uint64_t poses_received = 0;
    std::vector<double> pose_ages_ms, avatar_latencies_ms;
    std::optional<session::AvatarCamera> camera;
    std::shared_ptr<const std::vector<uint8_t>> avatar_payload;  // newest AvatarFrame payload
    int64_t first_avatar_rx_us = 0, last_avatar_rx_us = 0;
    uint64_t avatars_received = 0;
    // Decoding, on whoever asks (guarded by decode_mutex).
    std::unique_ptr<DepthDecoder> depth_decoder;
    std::unique_ptr<ColorDecoder> color_decoder;
    uint64_t decoded_sequence = 0;
    std::shared_ptr<const CameraFrame> decoded;
  };
  std::shared_ptr<const session::SharedCase> shared_case;
  struct Track {
    session::ObjectState newest;
    std::deque<std::pair<int64_t, Pose>> poses;  // (server time, room_from_object), oldest first
    Pose own;                                    // where this participant last moved it
  };
  std::vector<Track> objects;
  std::optional<session::MonitorState> monitor;
  std::map<uint32_t, std::shared_ptr<Remote>> remotes;
  std::map<uint32_t, std::shared_ptr<Remote>> gone;  // those who left, for stats()
  std::mutex decode_mutex;

  Impl(Client& c, ParticipantConfig cfg) : client(c), config(std::move(cfg)) {}

  int64_t server_now() const { return wall_clock_us() + offset_us; }

  std::atomic<bool> detached{false};

  void post(Type type, std::span<const uint8_t> payload, uint64_t key = 0) {
    if (!detached) client.post_session(session::message(type, payload), key);
  }

  // A case: megabytes, parsed before taking the lock, so that snapshots (every frame) do not wait.
  void handle_case(std::span<const uint8_t> p) {
    auto c = std::make_shared<session::SharedCase>(session::parse_case(p));
    std::lock_guard lock(mutex);
    objects.assign(c->objects.size(), Track{});
    for (size_t i = 0; i < c->objects.size(); ++i) {
      objects[i].newest.generation = c->generation;
      objects[i].newest.object = static_cast<uint16_t>(i);
      objects[i].newest.pose = objects[i].own = c->objects[i].rest;
    }
    monitor.reset();
    spdlog::info("session: case '{}' received: {} objects{}", printable(c->name), c->objects.size(),
                 c->monitor ? ", a CT series" : "");
    shared_case = std::move(c);
  }

  void handle(uint8_t type, std::span<const uint8_t> p) {
    if (static_cast<Type>(type) == Type::kCase) return handle_case(p);
    const int64_t now_server = server_now();
    std::lock_guard lock(mutex);
    switch (static_cast<Type>(type)) {
      case Type::kSessionList:
        state.lobby = session::parse_session_list(p);
        return;
      case Type::kJoined: {
        const session::Joined j = session::parse_joined(p);
        state.joined = true;
        state.id = j.participant;
        state.session_name = j.session_name;
        state.spot = j.spot;
        state.room_from_site.rotation =
            Eigen::AngleAxisd(j.site_yaw, Eigen::Vector3d::UnitY()).toRotationMatrix();
        state.room_from_site.translation = j.site_translation.cast<double>();
        state.last_error.clear();
        spdlog::info("session: joined '{}' as participant {}", printable(j.session_name),
                     j.participant);
        if (config.camera) {
          session::AvatarCamera cam{config.camera->calibration, config.camera->depth_codec,
                                    config.camera->color_codec};
          post(Type::kAvatarCamera, session::serialize(cam));
        }
        return;
      }
      case Type::kSessionError:
        state.last_error = session::parse_error(p);
        spdlog::warn("session: the server says: {}", printable(state.last_error, 300));
        return;
      case Type::kParticipantJoined: {
        const session::ParticipantInfo info = session::parse_participant(p);
        if (info.id == state.id) return;
        auto r = std::make_shared<Remote>();
        r->info.id = info.id;
        r->info.name = info.name;
        r->info.role = info.role;
        r->info.has_camera = info.has_camera;
        r->info.spot = info.spot;
        remotes[info.id] = r;
        return;
      }
      case Type::kParticipantLeft: {
        const auto [id, why] = session::parse_left(p);
        if (const auto it = remotes.find(id); it != remotes.end()) {
          state.departed.emplace_back(id, it->second->info.name, why);
          if (state.departed.size() > 64) state.departed.erase(state.departed.begin());
          gone[id] = it->second;
          if (gone.size() > 64) gone.erase(gone.begin());
          remotes.erase(it);
        }
        return;
      }
      case Type::kPoseFrom: {
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
        return;
      }
      case Type::kPoseEchoFrom: {
        const auto [from, sequence] = session::parse_echo(p);
        const auto it = pose_sent_us.find(sequence);
        if (it != pose_sent_us.end())
          add_sample(round_trips_ms, double(steady_us() - it->second) / 1000.0);
        return;
      }
      case Type::kTeleported: {
        const session::Teleported t = session::parse_teleported(p);
        if (t.participant == state.id) state.spot = t.to;
        if (const auto it = remotes.find(t.participant); it != remotes.end())
          it->second->info.spot = t.to;
        state.teleports.push_back({t.participant, t.from, t.to, t.time_us});
        if (state.teleports.size() > 16) state.teleports.erase(state.teleports.begin());
        return;
      }
      case Type::kAvatarCameraFrom: {
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
        return;
      }
      case Type::kAvatarFrameFrom: {
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
        return;
      }
      case Type::kCase:
        return;  // parsed before the lock (handle_case)
      case Type::kObjectState: {
        const session::ObjectState o = session::parse_object_state(p);
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
        return;
      }
      case Type::kMonitorState: {
        const session::MonitorState m = session::parse_monitor_state(p);
        if (!shared_case || m.generation != shared_case->generation) return;
        monitor = m;
        return;
      }
      default:
        throw Error("the server sent session message type " + std::to_string(type) +
                    ", which a participant does not take");
    }
  }

  // A move or release of `object` at `pose` (shown here at once), coalesced per object.
  void post_object(Type type, uint16_t object, const Pose& pose) {
    session::ObjectRequest q{0, object, pose};
    {
      std::lock_guard lock(mutex);
      if (!shared_case || object >= objects.size()) return;
      q.generation = shared_case->generation;
      objects[object].own = pose;
    }
    post(type, session::serialize(q, true), (uint64_t{3} << 32) | object);
  }

  void send_join(const std::string& name, bool create) {
    session::Join j;
    j.session = name;
    j.create = create;
    j.name = config.name;
    j.role = session::Role::kRemote;  // the only role a Join may ask for (hub.hpp)
    j.has_camera = config.camera.has_value();
    post(Type::kJoin, session::serialize(j));
  }
};

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
  if (m.detached) return;
  m.detached = true;
  m.client.set_session_handler(nullptr, nullptr);
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
  }
  return s;
}

std::shared_ptr<const session::SharedCase> Participant::shared_case() const {
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

void Participant::set_monitor(const session::MonitorState& state) {
  Impl& m = *impl_;
  session::MonitorState s = state;
  {
    std::lock_guard lock(m.mutex);
    if (!m.shared_case) return;
    s.generation = m.shared_case->generation;
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
    s.others.push_back(std::move(o));
  }
  return s;
}

int64_t Participant::clock_offset_us() const {
  return impl_->offset_us;
}

}  // namespace volcast
