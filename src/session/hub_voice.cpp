// A SessionHub's voices (voice_messages.hpp): each participant's packets forwarded unchanged to
// the other members of its session and to the OR site's loudspeaker; the OR site's microphone to
// everyone.
#include <spdlog/spdlog.h>

#include "hub_state.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/text.hpp"

namespace volcast {

void SessionHub::broadcast_voice(uint32_t from, const Shared& message, const Session& s) {
  for (const auto& [pid, other] : s.members)
    if (pid != from && other->info.viewer != 0) {
      send_shared(other->info.viewer, message, voice_key(from));
      ++stats_.voice_out;
    }
}

void SessionHub::handle_voice(Member& m, Type type, std::span<const uint8_t> payload) {
  if (type == Type::kVoiceState) {
    const bool muted = session::parse_voice_state(payload);
    m.info.muted = muted;
    m.voice_state = share(session::forward(Type::kVoiceStateFrom, m.info.id, payload));
    for (const auto& [pid, other] : m.session->members)
      if (other.get() != &m)
        send_shared(other->info.viewer, m.voice_state, voice_state_key(m.info.id));
    return;
  }
  session::VoicePacketView packet;
  try {
    packet = session::parse_voice(payload);
  } catch (const Error& e) {
    // One bad packet loses only itself (a glitch of the sender's encoder); a run of them is a
    // hostile or broken sender, dropped like any malformed message.
    ++stats_.voice_malformed;
    if (++m.malformed_voice >= session::kMaxMalformedVoice)
      throw Error(std::string(e.what()) + " (" + std::to_string(m.malformed_voice) +
                  " malformed voice packets)");
    if (m.malformed_voice == 1)
      spdlog::warn("session: '{}': {}: the packet is dropped", printable(m.info.name), e.what());
    return;
  }
  ++stats_.voice_in;
  ++m.info.voice_packets;
  broadcast_voice(m.info.id, share(session::forward(Type::kVoiceFrom, m.info.id, payload)),
                  *m.session);
  if (config_.site_listener) config_.site_listener(m.info.id, packet);
}

void SessionHub::site_voice(const session::VoicePacketView& packet) {
  const Shared message =
      share(session::forward(Type::kVoiceFrom, kSiteParticipant, session::serialize(packet)));
  std::lock_guard lock(mutex_);
  ++stats_.voice_in;
  for (const auto& [id, s] : sessions_) broadcast_voice(kSiteParticipant, message, *s);
}

void SessionHub::site_voice_state(bool muted) {
  const Shared message = share(session::forward(Type::kVoiceStateFrom, kSiteParticipant,
                                                session::serialize_voice_state(muted)));
  std::lock_guard lock(mutex_);
  site_muted_ = muted;
  for (const auto& [id, s] : sessions_) {
    Member& site = *s->members.at(kSiteParticipant);
    site.info.muted = muted;
    site.voice_state = message;
    for (const auto& [pid, other] : s->members)
      send_shared(other->info.viewer, message, voice_state_key(kSiteParticipant));
  }
}

}  // namespace volcast
