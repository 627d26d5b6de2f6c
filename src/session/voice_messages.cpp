#include "volcast/session/voice_messages.hpp"

#include <string>

#include "wire_fields.hpp"

namespace volcast::session {

using namespace fields;

template <typename Io, Of<VoicePacketView> M>
void layout(Io& io, M& m) {
  io.number(m.sequence);
  io.number(m.frame);
  io.number(m.capture_us);
  io.bytes(m.opus);
  io.check(!m.opus.empty() && m.opus.size() <= kMaxVoiceOpusBytes,
           "the Opus packet must be 1 to 1275 bytes");
}

namespace {
struct VoiceState {
  bool muted = false;
};
template <typename Io, Of<VoiceState> M>
void layout(Io& io, M& m) {
  io.flag(m.muted, "muted is neither 0 nor 1");
}
}  // namespace

std::vector<uint8_t> serialize(const VoicePacketView& m) {
  return encode(m, Fields{}, 20 + m.opus.size());
}

VoicePacketView parse_voice(std::span<const uint8_t> p) {
  return decode<VoicePacketView>(p, "voice");
}

std::vector<uint8_t> serialize_voice_state(bool muted) {
  return encode(VoiceState{muted});
}

bool parse_voice_state(std::span<const uint8_t> p) {
  return decode<VoiceState>(p, "voice state").muted;
}

}  // namespace volcast::session
