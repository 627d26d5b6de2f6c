// A SessionHub's patient case (hub.hpp): the case every participant receives, who holds which
// object and where it is, what the monitor shows.
#include <spdlog/spdlog.h>

#include "hub_state.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/text.hpp"
#include "volcast/core/wire.hpp"
#include "volcast/session/names.hpp"

namespace volcast {

void SessionHub::reset_case_state(Session& s) {
  s.objects.clear();
  s.monitor.reset();
  if (!case_) return;
  for (size_t i = 0; i < case_->objects.size(); ++i) {
    session::ObjectState o;
    o.generation = case_generation_;
    o.object = static_cast<uint16_t>(i);
    o.time_us = wall_clock_us();
    o.pose = case_->objects[i].rest;
    s.objects.push_back(o);
  }
  if (case_->monitor) {
    MonitorState m;
    m.generation = case_generation_;
    m.slice = static_cast<uint16_t>(case_->monitor->slices / 2);
    m.center = 40, m.width = 400;  // abdomen (dicom.hpp's presets)
    m.overlay = !case_->monitor->overlay.empty();
    s.monitor = m;
  }
}

void SessionHub::send_case_state(const Session& s, uint64_t viewer) {
  if (!case_message_) return;
  send_shared(viewer, case_message_);
  for (const session::ObjectState& o : s.objects)
    send(viewer, session::message(Type::kObjectState, session::serialize(o)), object_key(o.object));
  if (s.monitor)
    send(viewer, session::message(Type::kMonitorState, session::serialize(*s.monitor)),
         kMonitorKey);
}

void SessionHub::set_case(SharedCase c) {
  // Serialised before taking the lock (megabytes): poses keep flowing meanwhile. The generation,
  // the payload's first field, is filled in under the lock.
  std::vector<uint8_t> payload = session::serialize(c);
  std::lock_guard lock(mutex_);
  c.generation = case_generation_ + 1;
  wire::store<uint32_t>(payload.data(), c.generation);
  auto message = share(session::message(Type::kCase, payload));
  case_generation_ = c.generation;
  case_ = std::make_shared<const SharedCase>(std::move(c));
  case_message_ = std::move(message);
  ++stats_.case_swaps;
  for (auto& [id, s] : sessions_) {
    reset_case_state(*s);
    erase_stale_annotations(*s);
    for (const auto& [pid, member] : s->members) send_case_state(*s, member->info.viewer);
  }
  spdlog::info("session: case '{}' (generation {}) shared: {} objects{}", printable(case_->name),
               case_generation_, case_->objects.size(), case_->monitor ? ", a CT series" : "");
}

uint32_t SessionHub::case_generation() const {
  std::lock_guard lock(mutex_);
  return case_generation_;
}

std::vector<session::ObjectState> SessionHub::objects(const std::string& name) const {
  std::lock_guard lock(mutex_);
  for (const auto& [id, s] : sessions_)
    if (s->name == name) return s->objects;
  return {};
}

std::string SessionHub::case_name() const {
  std::lock_guard lock(mutex_);
  return case_ ? case_->name : std::string();
}

bool SessionHub::restore(const std::string& name, const std::string& case_name,
                         const std::vector<session::ObjectState>& objects,
                         const std::optional<MonitorState>& monitor) {
  session::Join j;  // the checks a Join's name gets
  j.session = name;
  j.name = "x";
  session::parse_join(session::serialize(j));
  const std::string checked = session::checked_name(name, "session name");
  std::lock_guard lock(mutex_);
  Session* s = &make_session(checked, false);  // kept if create_session made it
  if (!case_ || case_->name != case_name) return false;
  for (const session::ObjectState& o : objects) {
    if (o.object >= s->objects.size()) continue;
    session::ObjectState& to = s->objects[o.object];
    to.pose = o.pose;
    to.owner = 0;
    to.sequence = o.sequence;
    to.time_us = wall_clock_us();
  }
  if (monitor && s->monitor && case_->monitor) {
    s->monitor->slice =
        std::min<uint16_t>(monitor->slice, static_cast<uint16_t>(case_->monitor->slices - 1));
    s->monitor->center = monitor->center;
    s->monitor->width = monitor->width;
    s->monitor->overlay = monitor->overlay && !case_->monitor->overlay.empty();
  }
  spdlog::info("session '{}': objects and monitor of case '{}' restored", printable(name),
               printable(case_name));
  return true;
}

std::optional<MonitorState> SessionHub::monitor(const std::string& name) const {
  std::lock_guard lock(mutex_);
  for (const auto& [id, s] : sessions_)
    if (s->name == name) return s->monitor;
  return std::nullopt;
}

void SessionHub::broadcast_object(const Session& s, uint16_t object, const Member* except) {
  const Shared msg =
      share(session::message(Type::kObjectState, session::serialize(s.objects.at(object))));
  for (const auto& [pid, other] : s.members)
    if (other.get() != except) send_shared(other->info.viewer, msg, object_key(object));
}

std::span<const SessionHub::Route> SessionHub::object_routes() {
  static constexpr Route kRoutes[] = {
      {Type::kGrab, nullptr, &SessionHub::on_grab},
      {Type::kObjectMove, nullptr, &SessionHub::on_object_move},
      {Type::kRelease, nullptr, &SessionHub::on_release},
      {Type::kSetMonitor, nullptr, &SessionHub::on_set_monitor},
  };
  return kRoutes;
}

void SessionHub::on_set_monitor(Member& m, Payload payload) {
  Session& s = *m.session;
  MonitorState want = session::parse_set_monitor(payload);
  if (want.generation != case_generation_ || !s.monitor) return;  // about another case
  if (want.slice >= case_->monitor->slices)
    return error(m.info.viewer, "monitor: slice " + std::to_string(want.slice) + " of " +
                                    std::to_string(case_->monitor->slices));
  want.by = m.info.id;
  s.monitor = want;
  ++stats_.monitor_changes;
  const Shared msg = share(session::message(Type::kMonitorState, session::serialize(want)));
  for (const auto& [pid, other] : s.members) send_shared(other->info.viewer, msg, kMonitorKey);
}

void SessionHub::on_object_request(Member& m, Type type, Payload payload) {
  Session& s = *m.session;
  const session::ObjectRequest q = session::parse_object_request(payload, type != Type::kGrab);
  if (q.generation != case_generation_) return;  // sent before a swap
  if (q.object >= s.objects.size())
    throw Error("object " + std::to_string(q.object) + " does not exist (the case has " +
                std::to_string(s.objects.size()) + ")");
  session::ObjectState& o = s.objects[q.object];
  const std::string& name = case_->objects[q.object].name;
  switch (type) {
    case Type::kGrab:
      if (o.owner != 0 && o.owner != m.info.id) {
        ++stats_.grabs_refused;
        std::string holder = "participant " + std::to_string(o.owner);
        if (const auto h = s.members.find(o.owner); h != s.members.end())
          holder = h->second->info.name;
        return error(m.info.viewer, "'" + name + "' is held by '" + holder + "'");
      }
      o.owner = m.info.id;
      ++stats_.grabs;
      break;
    case Type::kObjectMove:
      if (o.owner != m.info.id) {
        ++stats_.moves_ignored;
        return;
      }
      o.pose = q.pose;
      ++stats_.object_moves;
      break;
    case Type::kRelease:
      if (o.owner != m.info.id) {
        ++stats_.moves_ignored;
        return;
      }
      o.pose = q.pose;
      o.owner = 0;
      ++stats_.releases;
      break;
    default:
      return;
  }
  ++o.sequence;
  o.time_us = wall_clock_us();
  // A move goes to the others (the owner knows where it put it); grab and release to everyone.
  broadcast_object(s, q.object, type == Type::kObjectMove ? &m : nullptr);
}

}  // namespace volcast
