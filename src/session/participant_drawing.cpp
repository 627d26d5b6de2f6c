// A Participant's pointing and drawing (participant.hpp): the others' laser pointers (0x50) and
// the session's annotations (0x51, erased by 0x52), handed on to the drawing handler.
#include "participant_impl.hpp"

namespace volcast {

std::span<const Participant::Impl::Route> Participant::Impl::drawing_routes() {
  static constexpr Route kRoutes[] = {
      {Type::kPointerFrom, &Impl::on_pointer},
      {Type::kAnnotation, &Impl::on_annotation, false},
      {Type::kErased, &Impl::on_erased, false},
  };
  return kRoutes;
}

void Participant::Impl::on_pointer(Payload p, int64_t now_server) {
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

void Participant::Impl::on_annotation(Payload p, int64_t) {
  session::Annotation a = session::parse_annotation(p);
  {
    std::lock_guard lock(mutex);
    annotations[a.id] = std::move(a);
  }
  std::lock_guard lock(voice_mutex);
  if (drawing_handler) drawing_handler(static_cast<uint8_t>(Type::kAnnotation), p);
}

void Participant::Impl::on_erased(Payload p, int64_t) {
  const uint32_t id = session::parse_erased(p).first;
  {
    std::lock_guard lock(mutex);
    annotations.erase(id);
  }
  std::lock_guard lock(voice_mutex);
  if (drawing_handler) drawing_handler(static_cast<uint8_t>(Type::kErased), p);
}

}  // namespace volcast
