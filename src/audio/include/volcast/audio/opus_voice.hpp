#pragma once
// Volcast voice over libopus (RFC 6716; https://opus-codec.org/docs/opus_api-1.3.1/): 48 kHz
// mono, one 20 ms frame (kFrameSamples) per packet, OPUS_APPLICATION_VOIP, in-band FEC and DTX.
#include <array>
#include <cstdint>
#include <memory>
#include <span>

#include "volcast/audio/voice_format.hpp"

namespace volcast::audio {

/// Encoder settings (libopus CTLs of the same names).
struct VoiceEncoderConfig {
  int bitrate_bps = 32000;        ///< OPUS_SET_BITRATE, bits per second
  bool fec = true;                ///< OPUS_SET_INBAND_FEC: each packet carries the previous frame
  bool dtx = true;                ///< OPUS_SET_DTX: silence gives <= 2-byte packets (not sent)
  int expected_loss_percent = 5;  ///< OPUS_SET_PACKET_LOSS_PERC (sizes the FEC)
  int complexity = 5;             ///< OPUS_SET_COMPLEXITY, 0..10
};

/// Encodes 20 ms mono frames to Opus packets. Owns an OpusEncoder; movable, not copyable.
class VoiceEncoder {
 public:
  /// Throws volcast::Error naming the setting libopus rejected.
  explicit VoiceEncoder(VoiceEncoderConfig config = {});
  ~VoiceEncoder();
  VoiceEncoder(VoiceEncoder&&) noexcept;
  VoiceEncoder& operator=(VoiceEncoder&&) noexcept;

  /// Encodes one frame (float [-1, 1], 48 kHz). Returns the packet (1..kMaxOpusPacketBytes
  /// bytes) in an internal buffer valid until the next call. When last_was_dtx() the packet is a
  /// DTX frame (<= 2 bytes) and need not be sent. Throws volcast::Error if libopus fails.
  std::span<const uint8_t> encode(std::span<const float, kFrameSamples> pcm);
  /// Whether the last encode() produced a DTX frame (silence: skip sending it).
  bool last_was_dtx() const { return last_was_dtx_; }

 private:
  struct Codec;
  std::unique_ptr<Codec> codec_;
  std::array<uint8_t, kMaxOpusPacketBytes> packet_{};
  bool last_was_dtx_ = false;
};

/// Decodes one speaker's packets, in order, to 20 ms mono frames. Owns an OpusDecoder; movable,
/// not copyable. No allocation per call.
class VoiceDecoder {
 public:
  VoiceDecoder();
  ~VoiceDecoder();
  VoiceDecoder(VoiceDecoder&&) noexcept;
  VoiceDecoder& operator=(VoiceDecoder&&) noexcept;

  /// Decodes `packet` into `out` (float [-1, 1]). Throws volcast::Error("malformed voice packet:
  /// ...") if it is not is_voice_packet() or libopus rejects it.
  void decode(std::span<const uint8_t> packet, std::span<float, kFrameSamples> out);
  /// Recovers the frame before `next_packet` (whose own frame is lost) from next_packet's
  /// in-band FEC; libopus falls back to PLC if it carries none. Throws as decode() for a
  /// malformed `next_packet`. Decode next_packet itself with decode() afterwards.
  void decode_fec(std::span<const uint8_t> next_packet, std::span<float, kFrameSamples> out);
  /// Packet-loss concealment (Opus PLC; comfort noise after DTX) for a frame with no packet.
  void conceal(std::span<float, kFrameSamples> out);
  /// Keeps the decoder's state (libopus: a flat, position-independent structure that "can be
  /// freely copied", opus.h) for restore(). Copies into storage the constructor allocated: no
  /// allocation.
  void save();
  /// Goes back to the state save() kept (the initial state if save() was never called): a stream
  /// that resumes after a stall decodes its next packet as if the concealment played meanwhile
  /// had not been.
  void restore();

 private:
  struct Codec;
  std::unique_ptr<Codec> codec_;
};

/// Whether `packet` is one Volcast voice packet: 1..kMaxOpusPacketBytes bytes, a well-formed Opus
/// packet (opus_packet_parse) of mono frames totalling exactly 20 ms (960 samples at 48 kHz).
/// Cheap (TOC and frame lengths only, no decoding): for receivers validating before queueing.
bool is_voice_packet(std::span<const uint8_t> packet);

}  // namespace volcast::audio
