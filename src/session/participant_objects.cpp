// A Participant's patient case (participant.hpp): the case (0x4b), its objects' owners and
// poses (0x4c) and the monitor's shared state (0x4d).
#include "participant_impl.hpp"

namespace volcast {
namespace {

// Whether two monitor states show the same (who set them aside).
bool same_view(const MonitorState& a, const MonitorState& b) {
  return a.generation == b.generation && a.slice == b.slice && a.center == b.center &&
         a.width == b.width && a.overlay == b.overlay;
}

}  // namespace

std::span<const Participant::Impl::Route> Participant::Impl::object_routes() {
  static constexpr Route kRoutes[] = {
      {Type::kCase, &Impl::on_case, false},
      {Type::kObjectState, &Impl::on_object_state},
      {Type::kMonitorState, &Impl::on_monitor_state},
  };
  return kRoutes;
}

void Participant::Impl::on_case(Payload p, int64_t) {
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

void Participant::Impl::on_object_state(Payload p, int64_t) {
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
}

void Participant::Impl::on_monitor_state(Payload p, int64_t) {
  const MonitorState m = session::parse_monitor_state(p);
  if (!shared_case || m.generation != shared_case->generation) return;
  monitor = m;
  if (monitor_sent && same_view(monitor_sent->first, m)) monitor_sent.reset();  // it arrived
}

}  // namespace volcast
