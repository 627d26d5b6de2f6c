#pragma once
// Internal to volcast_audio: what VoiceStream's two playout buffers share (voice_stream.cpp) —
// the buffered packet, the received-sequence window, and the player that decodes, conceals and
// counts (the loss rule of voice_stream.hpp) — and the two buffers themselves: speexdsp's adaptive
// jitter buffer (speexdsp_buffer.cpp) and Volcast's talk-spurt buffer (spurt_buffer.cpp).
#include <cstdint>
#include <memory>
#include <span>

#include "volcast/audio/opus_voice.hpp"
#include "volcast/audio/voice_stream.hpp"

namespace volcast::audio::detail {

inline int32_t diff(uint32_t a, uint32_t b) {
  return static_cast<int32_t>(a - b);
}

constexpr int32_t kRestartPackets = 250;  // a sequence 5 s of packets back: the sender restarted

/// One buffered packet (bytes copied in: no allocation per packet).
struct Slot {
  void* owner = nullptr;  // the buffer holding it (speexdsp's destroy callback finds it)
  bool held = false;
  uint32_t sequence = 0;
  uint32_t frame = 0;
  int64_t capture_us = 0;
  uint32_t len = 0;
  uint8_t bytes[kMaxOpusPacketBytes];
};

/// The received sequence numbers: the highest and a 64-bit window below it.
struct SequenceWindow {
  bool have = false;
  uint32_t highest = 0;
  uint64_t bits = 0;
  /// Whether `sequence` is new; counts a duplicate, or one more than 64 behind, in `stats`.
  bool note(uint32_t sequence, VoiceStreamStats& stats);
  /// Whether `sequence` is more than kRestartPackets behind the highest (the sender restarted).
  bool restarted(uint32_t sequence) const {
    return have && diff(sequence, highest) < -kRestartPackets;
  }
};

/// Decodes, conceals and counts one speaker's frames as they are played, by frame number, and
/// applies the loss rule (voice_stream.hpp) to gaps between played packets.
struct VoicePlayer {
  VoiceDecoder decoder;
  VoiceStreamStats stats;
  bool started = false;   // a packet has played
  bool talking = false;   // the last frame played was speech (packet, FEC or a lost frame)
  uint32_t last_seq = 0;  // the last packet played
  uint32_t last_frame = 0;
  int64_t last_capture_us = 0;
  uint32_t since_last = 0;  // frames played since it
  uint64_t pending = 0;     // gap frames played as provisional silence

  /// The stream stalled and resumes at the packet after the last one played: the frames played
  /// since count as inserted (a pause), and the decoder goes back to where that packet left it.
  void resume();
  /// The sender restarted at `sequence`/`frame`: count from there.
  void restart_sequence(uint32_t sequence, uint32_t frame);
  /// Plays `slot`'s packet: decode() then played().
  PlayedFrame play_packet(const Slot& slot, std::span<float, kFrameSamples> out) {
    return played(slot, decode(slot, out));
  }
  /// Decodes `slot`'s packet into `out`; false (and `out` concealed) where libopus rejects it.
  /// Follow with played() or skipped().
  bool decode(const Slot& slot, std::span<float, kFrameSamples> out);
  /// Counts `slot`'s decoded packet as played.
  PlayedFrame played(const Slot& slot, bool decoded);
  /// Counts `slot`'s decoded packet as dropped to shrink the delay (stats.frames_skipped).
  void skipped(const Slot& slot);
  /// Plays frame `frame` whose packet is missing; `next`: the earliest later packet buffered.
  PlayedFrame play_missing(uint32_t frame, const Slot* next, std::span<float, kFrameSamples> out);
  /// A frame inserted to grow the delay, standing for `frame`: concealed if `as_speech`, else
  /// silence (stats.frames_inserted).
  PlayedFrame play_insertion(uint32_t frame, bool as_speech, std::span<float, kFrameSamples> out);
  /// A frame with nothing to play (before the first packet: zeros).
  PlayedFrame play_idle(std::span<float, kFrameSamples> out);

 private:
  void resolve_gap(uint32_t sequence, uint32_t frame);
  /// One more frame played without a packet: at the first, the decoder's state is saved.
  void left_packet() {
    if (since_last++ == 0) decoder.save();
  }
  void advance(const Slot& slot);
  PlayedFrame estimate(PlayedFrame::Source source, uint32_t frame) const {
    return {source, frame, last_capture_us + int64_t{diff(frame, last_frame)} * kFrameUs};
  }
};

/// A playout buffer: VoiceStream's put/next/stats (voice_stream.hpp).
class Buffer {
 public:
  virtual ~Buffer() = default;
  virtual void put(uint32_t sequence, uint32_t frame, int64_t capture_us,
                   std::span<const uint8_t> packet) = 0;
  virtual PlayedFrame next(std::span<float, kFrameSamples> out) = 0;
  virtual void hold() = 0;
  virtual const VoiceStreamStats& stats() const = 0;
};

std::unique_ptr<Buffer> make_speexdsp_buffer(const VoiceStreamConfig& config);
std::unique_ptr<Buffer> make_spurt_buffer(const VoiceStreamConfig& config);

}  // namespace volcast::audio::detail
