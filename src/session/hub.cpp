#include "volcast/session/hub.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <condition_variable>

#include "hub_state.hpp"
#include "routes.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/text.hpp"
#include "volcast/session/message_table.hpp"
#include "volcast/session/names.hpp"

namespace volcast {

SessionHub::SessionHub(SessionHubConfig config) : config_(std::move(config)) {
  if (config_.presence_timeout_ms < 100)
    throw Error("session: presence timeout must be at least 100 ms");
  if (config_.max_sessions < 1 || config_.max_participants < 2)
    throw Error("session: need at least 1 session and 2 participants per session");
  if (config_.unjoined_session_ms < 0) throw Error("session: unjoined_session_ms must be >= 0");
  presence_ = std::thread([this] { watch_presence(); });
}

SessionHub::~SessionHub() {
  stopping_ = true;
  presence_.join();
}

void SessionHub::attach(SessionOutlet* server) {
  std::lock_guard lock(mutex_);
  server_ = server;
}

void SessionHub::attach_remote(SessionOutlet* remote) {
  std::lock_guard lock(mutex_);
  remote_ = remote;
}

uint32_t SessionHub::max_payload(uint8_t type) const {
  // A known type the server sends (0x41..) is read and refused by handle(), which counts it.
  return session::max_payload(type);
}

SessionHub::Session& SessionHub::make_session(const std::string& name, bool standing) {
  for (auto& [id, s] : sessions_)
    if (s->name == name) {
      s->standing = s->standing || standing;
      return *s;
    }
  if (static_cast<int>(sessions_.size()) >= config_.max_sessions)
    throw Error("the server has " + std::to_string(config_.max_sessions) + " sessions already");
  auto s = std::make_unique<Session>();
  s->id = next_session_++;
  s->name = name;
  s->standing = standing;
  auto site = std::make_unique<Member>();
  site->info.id = kSiteParticipant;
  site->info.name = config_.site_name;
  site->info.role = session::Role::kOrSite;
  site->info.has_camera = true;
  site->session = s.get();
  site->info.muted = site_muted_;
  if (site_muted_)
    site->voice_state = share(session::forward(Type::kVoiceStateFrom, kSiteParticipant,
                                               session::serialize_voice_state(true)));
  s->members.emplace(kSiteParticipant, std::move(site));
  for (const Recorded& r : recorded_) add_recorded_member(*s, r);
  reset_case_state(*s);
  Session& ref = *s;
  sessions_.emplace(ref.id, std::move(s));
  spdlog::info("session '{}' created", printable(name));
  return ref;
}

void SessionHub::create_session(const std::string& name) {
  // The same checks a Join's name gets.
  session::Join j;
  j.session = name;
  j.name = "x";
  session::parse_join(session::serialize(j));
  const std::string checked = session::checked_name(name, "session name");
  std::lock_guard lock(mutex_);
  make_session(checked, true);
}

void SessionHub::prune(Session* s) {
  if (!s || s->standing || connected(*s) > 0) return;  // the OR site is always in it
  const auto it = sessions_.find(s->id);
  if (it == sessions_.end()) return;
  spdlog::info("session '{}' removed: nobody is in it", printable(s->name));
  sessions_.erase(it);
  ++stats_.sessions_removed;
}

std::vector<session::SessionSummary> SessionHub::sessions() const {
  std::lock_guard lock(mutex_);
  std::vector<session::SessionSummary> out;
  for (const auto& [id, s] : sessions_)
    out.push_back({id, s->name, static_cast<uint32_t>(s->members.size())});
  return out;
}

std::vector<SessionMember> SessionHub::members(const std::string& name) const {
  std::lock_guard lock(mutex_);
  std::vector<SessionMember> out;
  for (const auto& [id, s] : sessions_)
    if (s->name == name)
      for (const auto& [pid, m] : s->members) out.push_back(m->info);
  return out;
}

SessionHubStats SessionHub::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

void SessionHub::send_shared(uint64_t viewer, const Shared& message, uint64_t coalesce_key) {
  if (SessionOutlet* o = outlet(viewer); o && viewer != 0)
    o->send_session(viewer, message, coalesce_key);
}

void SessionHub::send(uint64_t viewer, std::vector<uint8_t> message, uint64_t coalesce_key) {
  send_shared(viewer, share(std::move(message)), coalesce_key);
}

void SessionHub::error(uint64_t viewer, const std::string& reason) {
  send(viewer, session::message(Type::kSessionError, session::serialize_error(reason)));
}

void SessionHub::on_message(uint64_t viewer, uint8_t type, std::span<const uint8_t> payload) {
  std::lock_guard lock(mutex_);
  ++stats_.messages_in;
  const session::Admission admitted = limiter_.admit(viewer, type, steady_us());
  if (!admitted.report.empty()) {
    const auto it = by_viewer_.find(viewer);
    spdlog::warn("session: {}: {}",
                 it == by_viewer_.end() ? "viewer " + std::to_string(viewer)
                                        : "'" + printable(it->second->info.name) + "'",
                 admitted.report);
    if (admitted.started) error(viewer, admitted.report);
  }
  if (!admitted.admitted) {
    ++stats_.rate_limited;
    if (const auto it = by_viewer_.find(viewer); it != by_viewer_.end())
      it->second->last_seen = Clock::now();  // present, if too talkative
    return;
  }
  try {
    handle(viewer, type, payload);
  } catch (const Error&) {
    // A malformed or hostile message: its sender is dropped (the server ends its connection and
    // calls on_viewer_left, which tells the others why).
    if (auto it = by_viewer_.find(viewer); it != by_viewer_.end()) it->second->dropping = true;
    ++stats_.dropped;
    throw;
  }
}

void SessionHub::on_viewer_left(uint64_t viewer, const std::string& why) {
  std::lock_guard lock(mutex_);
  if (const std::string dropped = limiter_.forget(viewer, steady_us()); !dropped.empty())
    spdlog::warn("session: viewer {} left: {}", viewer, dropped);
  const auto it = by_viewer_.find(viewer);
  if (it == by_viewer_.end()) return;
  const bool dropped = it->second->dropping;
  spdlog::info("session: '{}' {}: {}", printable(it->second->info.name),
               dropped ? "dropped" : "disconnected", printable(why, 200));
  remove(viewer, dropped ? session::LeftReason::kDropped : session::LeftReason::kDisconnected);
}

void SessionHub::remove(uint64_t viewer, session::LeftReason reason) {
  const auto it = by_viewer_.find(viewer);
  if (it == by_viewer_.end()) return;
  Member* m = it->second;
  Session* s = m->session;
  const uint32_t id = m->info.id;
  by_viewer_.erase(it);
  s->members.erase(id);  // m is gone from here
  for (session::ObjectState& o : s->objects)
    if (o.owner == id) {  // let go where it was
      o.owner = 0;
      ++o.sequence;
      o.time_us = wall_clock_us();
      broadcast_object(*s, o.object, nullptr);
    }
  const Shared left =
      share(session::message(Type::kParticipantLeft, session::serialize_left(id, reason)));
  for (const auto& [pid, other] : s->members) send_shared(other->info.viewer, left);
  ++stats_.leaves;
  prune(s);
}

void SessionHub::join(uint64_t viewer, const session::Join& request) {
  Session* s = nullptr;
  bool made = false;  // by this Join: removed again if the Join is refused
  const auto refuse = [&](const std::string& why) {
    ++stats_.joins_refused;
    if (made) prune(s);
    error(viewer, why);
  };
  if (const auto it = by_viewer_.find(viewer); it != by_viewer_.end())
    return refuse("already in session '" + it->second->session->name + "': leave it first");
  // The role is the server's to give: a viewer (the server's own or a relay's) is remote.
  if (request.role != session::Role::kRemote)
    return refuse("join refused: the role '" + std::string(session::to_string(request.role)) +
                  "' is the server's own (its cameras, participant 1); viewers join as remote");
  session::Join j = request;
  try {
    j.session = session::checked_name(j.session, "session name");
    j.name = session::checked_name(j.name, "display name");
  } catch (const Error& e) {
    return refuse(std::string("join refused: ") + e.what());
  }
  for (auto& [id, candidate] : sessions_)
    if (candidate->name == j.session) s = candidate.get();
  if (!s) {
    if (!j.create) return refuse("no session named '" + j.session + "'");
    const session::Admission a = limiter_.admit_creation(viewer, steady_us());
    if (!a.report.empty()) spdlog::warn("session: '{}': {}", printable(j.name), a.report);
    if (!a.admitted)
      return refuse("session '" + j.session + "' not made: over the limit per participant (" +
                    session::to_string(session::kSessionCreation) + ")");
    try {
      s = &make_session(j.session, false);
      made = true;
    } catch (const Error& e) {
      return refuse(e.what());
    }
  }
  if (connected(*s) + 1 >= config_.max_participants)  // the OR site is one
    return refuse("session '" + s->name + "' is full (" + std::to_string(config_.max_participants) +
                  " participants)");
  const std::string skeleton = session::name_skeleton(j.name);
  for (const auto& [pid, other] : s->members) {
    if (other->info.name == j.name && j.rejoin_key != std::array<uint64_t, 2>{} &&
        other->rejoin_key == j.rejoin_key && other->info.viewer != 0)
      return take_over(viewer, *other);
    if (other->info.name == j.name)
      return refuse("the name '" + j.name + "' is taken in session '" + s->name + "'");
    if (session::name_skeleton(other->info.name) == skeleton)
      return refuse("the name '" + j.name + "' looks like '" + other->info.name +
                    "', already in session '" + s->name + "': choose another");
  }
  const session::Spot spot = free_spot(*s, false);
  auto member = std::make_unique<Member>();
  Member& m = *member;
  m.info.id = returning_id(*s, j);
  if (m.info.id == 0) m.info.id = next_participant_++;
  m.info.viewer = viewer;
  m.info.name = j.name;
  m.info.role = session::Role::kRemote;
  m.info.has_camera = j.has_camera;
  m.info.spot = spot;
  m.session = s;
  m.rejoin_key = j.rejoin_key;
  welcome_member(viewer, m);
  const Shared announce = share(
      session::message(Type::kParticipantJoined,
                       session::serialize(session::ParticipantInfo{
                           m.info.id, m.info.name, m.info.role, m.info.has_camera, m.info.spot})));
  for (const auto& [pid, other] : s->members) send_shared(other->info.viewer, announce);
  s->members.emplace(m.info.id, std::move(member));
  by_viewer_[viewer] = &m;
  ++stats_.joins;
  spdlog::info("session '{}': '{}' joined as participant {} ({}{})", printable(s->name),
               printable(j.name), m.info.id, session::to_string(m.info.role),
               j.has_camera ? ", with a camera" : "");
}

// Sends a member joining on `viewer` what it needs: Joined, then each other participant (with
// its camera, newest pose and voice state), the case and the drawing.
void SessionHub::welcome_member(uint64_t viewer, const Member& m) {
  const Session& s = *m.session;
  session::Joined joined;
  joined.participant = m.info.id;
  joined.session = s.id;
  joined.session_name = s.name;
  joined.spot = m.info.spot;
  joined.site_translation = config_.site_translation;
  joined.site_yaw = config_.site_yaw;
  send(viewer, session::message(Type::kJoined, session::serialize(joined)));
  for (const auto& [pid, other] : s.members) {
    if (other.get() == &m) continue;
    session::ParticipantInfo info{other->info.id, other->info.name, other->info.role,
                                  other->info.has_camera, other->info.spot};
    send(viewer, session::message(Type::kParticipantJoined, session::serialize(info)));
    if (other->camera_message) send_shared(viewer, other->camera_message);
    if (other->last_pose) send_shared(viewer, other->last_pose, pose_key(other->info.id));
    if (other->voice_state) send_shared(viewer, other->voice_state);
  }
  if (recording_.recording)
    send(viewer, session::message(Type::kRecordingState, session::serialize(recording_)));
  send_case_state(s, viewer);
  send_drawing_state(s, viewer);
}

void SessionHub::start_recording(const std::string& by) {
  session::RecordingState r{true, wall_clock_us(), by};
  for (char& c : r.by)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = ' ';
  r.by = session::cut_utf8(r.by, session::kMaxRecorderBytes);
  std::lock_guard lock(mutex_);
  recording_ = std::move(r);
  broadcast_recording();
}

void SessionHub::stop_recording() {
  std::lock_guard lock(mutex_);
  if (!recording_.recording) return;
  recording_ = {};
  broadcast_recording();
}

session::RecordingState SessionHub::recording() const {
  std::lock_guard lock(mutex_);
  return recording_;
}

void SessionHub::broadcast_recording() {
  spdlog::info("session: {}",
               recording_.recording
                   ? "recording, by " + printable(recording_.by) + ": every viewer shows it"
                   : "the recording stopped: every viewer shows it");
  const Shared msg = share(session::message(Type::kRecordingState, session::serialize(recording_)));
  for (const auto& [id, s] : sessions_)
    for (const auto& [pid, m] : s->members) send_shared(m->info.viewer, msg);
}

// The id of a participant of session `s` that timed out (its heartbeats held up longer than the
// presence timeout: a stalled link or machine) and now joins again with the same name and rejoin
// key: the same person comes back as the same participant (annotations, pointers and the others'
// figures stay theirs). 0 for anyone else.
uint32_t SessionHub::returning_id(const Session& s, const session::Join& j) {
  const auto now = Clock::now();
  std::erase_if(timed_out_, [&](const TimedOut& t) {
    return now - t.at > std::chrono::milliseconds(kTimedOutKeptMs);
  });
  if (j.rejoin_key == std::array<uint64_t, 2>{}) return 0;
  for (auto it = timed_out_.begin(); it != timed_out_.end(); ++it)
    if (it->session == s.name && it->name == j.name && it->rejoin_key == j.rejoin_key &&
        !s.members.contains(it->id)) {
      const uint32_t id = it->id;
      timed_out_.erase(it);
      ++stats_.returns;
      spdlog::info("session '{}': '{}' is back after timing out, as participant {} again",
                   printable(s.name), printable(j.name), id);
      return id;
    }
  return 0;
}

// A member whose viewer reconnected (its Join's rejoin key is the member's): the new connection
// takes its place -- participant id, spot, held objects, annotations -- and the old one, whose
// path was cut, is closed. The others see nothing change.
void SessionHub::take_over(uint64_t viewer, Member& m) {
  const uint64_t old = m.info.viewer;
  by_viewer_.erase(old);
  m.info.viewer = viewer;
  m.last_seen = Clock::now();
  m.dropping = false;
  by_viewer_[viewer] = &m;
  welcome_member(viewer, m);
  ++stats_.rejoins;
  spdlog::info("session '{}': '{}' rejoined as participant {} (reconnected)",
               printable(m.session->name), printable(m.info.name), m.info.id);
  if (SessionOutlet* o = outlet(old)) o->disconnect(old, "replaced by its own reconnection");
  if (old & kRemoteViewer) limiter_.forget(old, steady_us());
}

int SessionHub::connected(const Session& s) {
  int n = 0;
  for (const auto& [id, m] : s.members) n += m->info.viewer != 0;
  return n;
}

// A free spawn spot: free floor, away from the other play areas; tried from the first (a
// participant joining) or from the last (a recorded speaker).
session::Spot SessionHub::free_spot(const Session& s, bool from_last) const {
  const std::vector<Eigen::Vector2f>& spots = config_.room.spawn_spots;
  const float clearance = 4 * config_.room.person_radius_m;
  for (size_t i = 0; i < spots.size(); ++i) {
    const Eigen::Vector2f& p = spots[from_last ? spots.size() - 1 - i : i];
    if (!is_free_floor_spot(config_.room, p)) continue;
    bool taken = false;
    for (const auto& [pid, other] : s.members)
      if (other->info.role == session::Role::kRemote &&
          Eigen::Vector2f(other->info.spot.x - p.x(), other->info.spot.z - p.y()).norm() <
              clearance)
        taken = true;
    if (taken) continue;
    // Face the table's centre.
    return {
        p.x(), p.y(),
        std::atan2(p.x() - config_.room.table.center.x(), p.y() - config_.room.table.center.z())};
  }
  if (spots.empty()) return {};
  const Eigen::Vector2f& p = from_last ? spots.back() : spots.front();  // all taken: share it
  return {p.x(), p.y(), 0};
}

// Every feature's routes, listed once.
std::span<const session::FeatureRoutes<SessionHub::Route>> SessionHub::features() {
  using session::Feature;
  static const session::FeatureRoutes<Route> kFeatures[] = {{presence_routes(), Feature::kPresence},
                                                            {avatar_routes(), Feature::kAvatars},
                                                            {voice_routes(), Feature::kVoice},
                                                            {drawing_routes(), Feature::kDrawing},
                                                            {object_routes(), Feature::kObjects}};
  return kFeatures;
}

const SessionHub::Route* SessionHub::route(uint8_t type) {
  static const auto routes = session::index_routes(features());
  return routes[type];
}

std::vector<std::pair<session::Type, session::Feature>> SessionHub::handled_types() {
  return session::routed_types(features());
}

bool SessionHub::in_session(uint64_t viewer, const Member* m, const char* what) {
  if (!m) error(viewer, std::string(what) + ": not in a session (join one first)");
  return m != nullptr;
}

void SessionHub::handle(uint64_t viewer, uint8_t type, std::span<const uint8_t> payload) {
  const auto it = by_viewer_.find(viewer);
  Member* m = it == by_viewer_.end() ? nullptr : it->second;
  if (m) m->last_seen = Clock::now();
  const Route* r = route(type);
  if (!r) throw Error("a participant may not send session message type " + std::to_string(type));
  if (r->anyone) return (this->*r->anyone)(viewer, m, payload);
  if (!in_session(viewer, m, session::find_message(type)->name)) return;
  (this->*r->member)(*m, payload);
}

// ---- Presence: the lobby, joining and leaving, poses and teleports ------------------------------

std::span<const SessionHub::Route> SessionHub::presence_routes() {
  static constexpr Route kRoutes[] = {
      {Type::kListSessions, &SessionHub::on_list_sessions},
      {Type::kJoin, &SessionHub::on_join},
      {Type::kLeave, &SessionHub::on_leave},
      {Type::kHeartbeat, &SessionHub::on_heartbeat},
      {Type::kPose, &SessionHub::on_pose},
      {Type::kPoseEcho, &SessionHub::on_pose_echo},
      {Type::kTeleport, &SessionHub::on_teleport},
  };
  return kRoutes;
}

void SessionHub::on_list_sessions(uint64_t viewer, Member*, Payload payload) {
  if (!payload.empty()) throw Error("malformed list sessions: not empty");
  std::vector<session::SessionSummary> list;
  for (const auto& [id, s] : sessions_)
    list.push_back({id, s->name, static_cast<uint32_t>(s->members.size())});
  send(viewer, session::message(Type::kSessionList, session::serialize(list)));
}

void SessionHub::on_join(uint64_t viewer, Member*, Payload payload) {
  join(viewer, session::parse_join(payload));
}

void SessionHub::on_leave(uint64_t viewer, Member* m, Payload payload) {
  if (!payload.empty()) throw Error("malformed leave: not empty");
  if (m) remove(viewer, session::LeftReason::kLeft);
}

void SessionHub::on_heartbeat(uint64_t, Member*, Payload payload) {
  if (!payload.empty()) throw Error("malformed heartbeat: not empty");
}

void SessionHub::on_pose(uint64_t viewer, Member* m, Payload payload) {
  const session::PoseMessage pose = session::parse_pose(payload);  // checked before anyone sees it
  if (!in_session(viewer, m, "pose")) return;
  ++stats_.poses_in;
  ++m->info.poses;
  if (pose.echo_wanted)
    m->echo_asks[m->echo_asks_made++ % kEchoAskWindow] = EchoAsked{true, pose.sequence, 0, {}};
  m->last_pose = share(session::forward(Type::kPoseFrom, m->info.id, payload));
  for (const auto& [pid, other] : m->session->members)
    if (other.get() != m && other->info.viewer != 0) {
      send_shared(other->info.viewer, m->last_pose, pose_key(m->info.id));
      ++stats_.pose_messages_out;
    }
}

void SessionHub::on_pose_echo(uint64_t viewer, Member* m, Payload payload) {
  const auto [origin, sequence] = session::parse_echo(payload);
  if (!in_session(viewer, m, "pose echo")) return;
  const auto o = m->session->members.find(origin);
  if (o == m->session->members.end()) return;  // left meanwhile
  // What one participant may make another receive is limited by the receiver: an answer to
  // one of its own recent poses that asked for one, once per answering participant. Anything
  // else (a flood addressed to one participant, an answer repeated or never asked for) is dropped
  // here and counted, the sender's other messages unaffected.
  Member& asker = *o->second;
  EchoAsked* ask = nullptr;
  for (EchoAsked& a : asker.echo_asks)
    if (a.asked && a.sequence == sequence) ask = &a;
  const bool answered =
      ask && std::find(ask->answered_by.begin(), ask->answered_by.begin() + ask->answers,
                       m->info.id) != ask->answered_by.begin() + ask->answers;
  if (!ask || answered || ask->answers == ask->answered_by.size() || &asker == m) {
    ++stats_.echoes_refused;
    return;
  }
  ask->answered_by[ask->answers++] = m->info.id;
  send(asker.info.viewer,
       session::message(Type::kPoseEchoFrom, session::serialize_echo(m->info.id, sequence)));
}

void SessionHub::on_teleport(uint64_t viewer, Member* m, Payload payload) {
  const session::Spot to = session::parse_teleport(payload);
  if (!in_session(viewer, m, "teleport")) return;
  std::string why;
  if (!is_free_floor_spot(config_.room, {to.x, to.z}, &why))
    return error(viewer, "teleport to (" + std::to_string(to.x) + ", " + std::to_string(to.z) +
                             ") refused: " + why);
  session::Teleported t{m->info.id, m->info.spot, to, wall_clock_us()};
  m->info.spot = to;
  const Shared msg = share(session::message(Type::kTeleported, session::serialize(t)));
  for (const auto& [pid, other] : m->session->members) send_shared(other->info.viewer, msg);
}

void SessionHub::watch_presence() {
  while (!stopping_) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    std::lock_guard lock(mutex_);
    const auto now = Clock::now();
    std::vector<uint64_t> silent;
    for (const auto& [viewer, m] : by_viewer_)
      if (now - m->last_seen > std::chrono::milliseconds(config_.presence_timeout_ms))
        silent.push_back(viewer);
    for (uint64_t viewer : silent) {
      const Member& m = *by_viewer_[viewer];
      spdlog::info("session: '{}' timed out (nothing for {} ms)", printable(m.info.name),
                   config_.presence_timeout_ms);
      if (m.rejoin_key != std::array<uint64_t, 2>{}) {
        if (timed_out_.size() == kMaxTimedOutKept) timed_out_.erase(timed_out_.begin());
        timed_out_.push_back({m.session->name, m.info.name, m.rejoin_key, m.info.id, now});
      }
      remove(viewer, session::LeftReason::kTimedOut);
      ++stats_.timeouts;
      if (SessionOutlet* o = outlet(viewer))
        o->disconnect(viewer, "session presence timeout: nothing for " +
                                  std::to_string(config_.presence_timeout_ms) + " ms");
      if (viewer & kRemoteViewer) limiter_.forget(viewer, steady_us());  // no on_viewer_left
    }
    // Restored sessions nobody joined (the others go when their last participant does).
    std::vector<Session*> unjoined;
    for (const auto& [id, s] : sessions_)
      if (!s->standing && connected(*s) == 0 &&
          now - s->made > std::chrono::milliseconds(config_.unjoined_session_ms))
        unjoined.push_back(s.get());
    for (Session* s : unjoined) prune(s);
  }
}

}  // namespace volcast
