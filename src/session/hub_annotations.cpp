// A SessionHub's pointers and annotations (annotations.hpp): each participant's laser pointer
// forwarded to the others, and the session's strokes, arrows and labels, kept for those who join
// later and for after their author left, within the session's limits.
#include <spdlog/spdlog.h>

#include "hub_state.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/text.hpp"

namespace volcast {

using session::Annotation;
using session::AnnotationAnchor;

std::vector<Annotation> SessionHub::annotations(const std::string& name) const {
  std::lock_guard lock(mutex_);
  std::vector<Annotation> out;
  for (const auto& [id, s] : sessions_)
    if (s->name == name)
      for (const auto& [aid, d] : s->annotations) out.push_back(d.annotation);
  return out;
}

void SessionHub::send_drawing_state(const Session& s, uint64_t viewer) {
  for (const auto& [id, d] : s.annotations) send_shared(viewer, d.message);
  for (const auto& [pid, other] : s.members)
    if (other->pointer) send_shared(viewer, other->pointer, pointer_key(pid));
}

void SessionHub::erase_stale_annotations(Session& s) {
  for (auto it = s.annotations.begin(); it != s.annotations.end();) {
    const Annotation& a = it->second.annotation;
    if (a.anchor != AnnotationAnchor::kMonitor || a.generation == case_generation_) {
      ++it;
      continue;
    }
    s.annotation_points -= a.points.size();
    const Shared msg = share(session::message(Type::kErased, session::serialize_erased(a.id, 0)));
    for (const auto& [pid, other] : s.members) send_shared(other->info.viewer, msg);
    it = s.annotations.erase(it);
  }
}

std::span<const SessionHub::Route> SessionHub::drawing_routes() {
  static constexpr Route kRoutes[] = {
      {Type::kPointer, nullptr, &SessionHub::on_pointer},
      {Type::kAnnotate, nullptr, &SessionHub::on_annotate},
      {Type::kErase, nullptr, &SessionHub::on_erase},
  };
  return kRoutes;
}

void SessionHub::on_pointer(Member& m, Payload payload) {
  Session& s = *m.session;
  const session::PointerMessage p = session::parse_pointer(payload);
  ++stats_.pointers_in;
  const Shared msg = share(session::forward(Type::kPointerFrom, m.info.id, payload));
  m.pointer = p.on ? msg : nullptr;
  for (const auto& [pid, other] : s.members)
    if (other.get() != &m && other->info.viewer != 0) {
      send_shared(other->info.viewer, msg, pointer_key(m.info.id));
      stats_.drawing_bytes_out += msg->size();
    }
}

void SessionHub::on_annotate(Member& m, Payload payload) {
  Session& s = *m.session;
  Annotation a = session::parse_annotate(payload);
  const auto refuse = [&](const std::string& why) {
    ++stats_.annotations_refused;
    error(m.info.viewer, "annotation refused: " + why);
  };
  if (a.kind == session::AnnotationKind::kLabel) try {
      a.text = session::check_label_text(a.text);
    } catch (const Error& e) {
      return refuse(e.what());
    }
  if (a.anchor == AnnotationAnchor::kMonitor) {
    if (!case_ || !case_->monitor || a.generation != case_generation_)
      return refuse("it is about the monitor of a case that is no longer shown");
    if (a.slice >= case_->monitor->slices)
      return refuse("slice " + std::to_string(a.slice) + " of " +
                    std::to_string(case_->monitor->slices));
  }
  if (s.annotations.size() >= session::kMaxSessionAnnotations)
    return refuse("the session holds " + std::to_string(s.annotations.size()) +
                  " annotations, its limit: erase some first");
  if (s.annotation_points + a.points.size() > session::kMaxSessionAnnotationPoints)
    return refuse("the session's annotations hold " + std::to_string(s.annotation_points) +
                  " points, and " + std::to_string(a.points.size()) + " more would pass its " +
                  "limit of " + std::to_string(session::kMaxSessionAnnotationPoints));
  a.id = s.next_annotation++;
  a.author = m.info.id;
  a.time_us = wall_clock_us();
  const Shared msg = share(session::message(Type::kAnnotation, session::serialize(a)));
  s.annotation_points += a.points.size();
  s.annotations.emplace(a.id, Session::Drawn{a, msg});
  ++stats_.annotations;
  for (const auto& [pid, other] : s.members)
    if (other->info.viewer != 0) {
      send_shared(other->info.viewer, msg);
      stats_.drawing_bytes_out += msg->size();
    }
}

void SessionHub::on_erase(Member& m, Payload payload) {
  Session& s = *m.session;
  const uint32_t id = session::parse_erase(payload);
  const auto it = s.annotations.find(id);
  if (it == s.annotations.end())
    return error(m.info.viewer, "erase: the session has no annotation " + std::to_string(id) +
                                    " (erased already?)");
  const Annotation& a = it->second.annotation;
  if (!config_.anyone_erases && a.author != m.info.id)
    return error(m.info.viewer, "erase: annotation " + std::to_string(id) +
                                    " is another participant's, and only its author may " +
                                    "erase it on this server");
  s.annotation_points -= a.points.size();
  s.annotations.erase(it);
  ++stats_.erases;
  const Shared msg =
      share(session::message(Type::kErased, session::serialize_erased(id, m.info.id)));
  for (const auto& [pid, other] : s.members)
    if (other->info.viewer != 0) {
      send_shared(other->info.viewer, msg);
      stats_.drawing_bytes_out += msg->size();
    }
}

}  // namespace volcast

namespace volcast {

bool SessionHub::recorded_drawing(uint8_t type, std::span<const uint8_t> payload, uint32_t as) {
  using session::Annotation;
  Annotation a;
  uint32_t recorded = 0;
  try {
    if (static_cast<Type>(type) == Type::kAnnotation) {
      a = session::parse_annotation(payload);
      recorded = a.id;
      if (a.kind == session::AnnotationKind::kLabel) a.text = session::check_label_text(a.text);
    } else if (static_cast<Type>(type) == Type::kErased) {
      recorded = session::parse_erased(payload).first;
    } else {
      return false;
    }
  } catch (const Error& e) {
    spdlog::warn("replay: a recorded annotation is not shown: {}", e.what());
    return false;
  }
  if (recorded == 0) return false;
  std::lock_guard lock(mutex_);
  if (static_cast<Type>(type) == Type::kAnnotation && a.anchor == AnnotationAnchor::kMonitor) {
    if (!case_ || !case_->monitor || a.slice >= case_->monitor->slices) return false;
    a.generation = case_generation_;
  }
  const auto erase = [&](Session& s) {
    for (auto it = s.annotations.begin(); it != s.annotations.end(); ++it)
      if (it->second.recorded == recorded) {
        const uint32_t id = it->first;
        s.annotation_points -= it->second.annotation.points.size();
        s.annotations.erase(it);
        ++stats_.erases;
        const Shared msg =
            share(session::message(Type::kErased, session::serialize_erased(id, as)));
        for (const auto& [pid, other] : s.members) send_shared(other->info.viewer, msg);
        return true;
      }
    return false;
  };
  bool changed = false;
  for (auto& [sid, sp] : sessions_) {
    Session& s = *sp;
    if (static_cast<Type>(type) == Type::kErased) {
      changed = erase(s) || changed;
      continue;
    }
    erase(s);  // the same recorded annotation again (a looping replay): the new one replaces it
    if (s.annotations.size() >= session::kMaxSessionAnnotations ||
        s.annotation_points + a.points.size() > session::kMaxSessionAnnotationPoints) {
      ++stats_.annotations_refused;
      continue;
    }
    Annotation mine = a;
    mine.id = s.next_annotation++;
    mine.author = as;
    mine.time_us = wall_clock_us();
    const Shared msg = share(session::message(Type::kAnnotation, session::serialize(mine)));
    s.annotation_points += mine.points.size();
    s.annotations.emplace(mine.id, Session::Drawn{mine, msg, recorded});
    ++stats_.annotations;
    for (const auto& [pid, other] : s.members) send_shared(other->info.viewer, msg);
    changed = true;
  }
  return changed;
}

}  // namespace volcast
