#include "volcast/session/voice_messages.hpp"

#include <string>

#include "feature_layouts.hpp"
#include "wire_fields.hpp"

namespace volcast::session {

using namespace fields;

template <typename Io, Of<VoicePacketView> M>
void layout(Io& io, M& m) {
  io.number(m.sequence, "sequence");
  io.number(m.frame, "frame");
  io.number(m.capture_us, "capture_us");
  io.bytes(m.opus, "opus");
  io.check(!m.opus.empty() && m.opus.size() <= kMaxVoiceOpusBytes,
           "the Opus packet must be 1 to 1275 bytes");
}

namespace {
struct VoiceState {
  bool muted = false;
};
template <typename Io, Of<VoiceState> M>
void layout(Io& io, M& m) {
  io.flag(m.muted, "muted");
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

bool describe_voice(Type type, std::vector<LayoutField>& out) {
  switch (type) {
    case Type::kVoice:
      out = describe<VoicePacketView>();
      return true;
    case Type::kVoiceFrom:
      out = forwarded(describe<VoicePacketView>());
      return true;
    case Type::kVoiceState:
      out = describe<VoiceState>();
      return true;
    case Type::kVoiceStateFrom:
      out = forwarded(describe<VoiceState>());
      return true;
    default:
      return false;
  }
}

}  // namespace volcast::session
