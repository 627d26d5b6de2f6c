#pragma once
// Voice in a session (issue 35): each participant's microphone as Opus packets (RFC 6716; 48 kHz
// mono, one 20 ms frame per packet, in-band FEC, DTX), carried on its authenticated session
// connection and forwarded by the server to the other members without being decoded (selective
// forwarding, no mixing). Session channel messages (header as messages.hpp); little-endian.
//
// participant -> server:
//   0x0e Voice        sequence u32 (+1 per packet sent) | frame u32 (+1 per 20 ms frame captured,
//                     sent or not: DTX skips the frames of silence) | capture time i64 (µs, the
//                     server's clock, of the frame's first sample) | Opus packet (byte string: u32
//                     length + bytes, 1..kMaxVoiceOpusBytes). The server stamps the sender (the
//                     connection's participant: nobody speaks as another) and forwards it as 0x4e
//                     to every other member of the sender's session, and to the OR site's
//                     loudspeaker. Every packet of one speaker waits for each receiver
//                     (session_port.hpp kQueuedStreamKey: up to kMaxQueuedPerStream while the
//                     receiver's connection is full, else kMaxHeldPerStream, 1 s): a slow
//                     receiver loses its oldest audio first and never delays the others.
//   0x0f VoiceState   muted u8 (0/1): the sender's microphone is muted (nothing is sent while it
//                     is). Forwarded as 0x4f to the others and sent to those who join later.
// server -> participant:
//   0x4e VoiceFrom    participant u32 | the 0x0e payload (participant 1: the OR site's microphone)
//   0x4f VoiceStateFrom participant u32 | the 0x0f payload
// A malformed voice packet (short, trailing bytes, an Opus length out of range) loses only that
// packet; its sender is dropped after kMaxMalformedVoice of them. A voice message over the
// message table's limit (message_table.hpp) drops its sender at once, like any message over its
// limit. The server does not parse the Opus bytes: receivers check them before decoding.
#include <cstdint>
#include <span>
#include <vector>

#include "volcast/session/messages.hpp"

namespace volcast::session {

inline constexpr size_t kMaxVoiceOpusBytes = 1275;  ///< RFC 6716 §3.4: one frame's largest
/// A Voice payload's largest size: sequence, frame, time, the byte string's length and bytes.
inline constexpr uint32_t kMaxVoicePayloadBytes = 4 + 4 + 8 + 4 + kMaxVoiceOpusBytes;
/// The message table's limit for 0x0e: larger than any valid one, so that a slightly oversized
/// packet loses only itself (a larger one drops its sender).
inline constexpr uint32_t kVoiceMessageLimit = 4096;
inline constexpr uint32_t kMaxMalformedVoice = 8;

/// A voice packet's fields; `opus` points into the parsed payload.
struct VoicePacketView {
  uint32_t sequence = 0;
  uint32_t frame = 0;
  int64_t capture_us = 0;  ///< server clock, first sample of the frame
  std::span<const uint8_t> opus;
};

std::vector<uint8_t> serialize(const VoicePacketView& m);
/// Throws Error("malformed voice: ...") on truncation, trailing bytes or an Opus length outside
/// 1..kMaxVoiceOpusBytes.
VoicePacketView parse_voice(std::span<const uint8_t> p);
/// 0x0f / 0x4f payload (after the participant): muted.
std::vector<uint8_t> serialize_voice_state(bool muted);
bool parse_voice_state(std::span<const uint8_t> p);

}  // namespace volcast::session
