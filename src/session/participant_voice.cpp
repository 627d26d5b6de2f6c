// A Participant's voices of the others (participant.hpp): their packets (0x4e), handed to the
// voice handler outside the state's lock, and their microphone states (0x4f).
#include "participant_impl.hpp"

namespace volcast {

std::span<const Participant::Impl::Route> Participant::Impl::voice_routes() {
  static constexpr Route kRoutes[] = {
      {Type::kVoiceFrom, &Impl::on_voice, false},
      {Type::kVoiceStateFrom, &Impl::on_voice_state},
  };
  return kRoutes;
}

void Participant::Impl::on_voice(Payload p, int64_t) {
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

void Participant::Impl::on_voice_state(Payload p, int64_t) {
  const auto [from, payload] = session::split_forwarded(p);
  const bool muted = session::parse_voice_state(payload);
  if (const auto it = remotes.find(from); it != remotes.end()) it->second->info.muted = muted;
}

}  // namespace volcast
