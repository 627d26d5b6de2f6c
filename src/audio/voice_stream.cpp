#include "volcast/audio/voice_stream.hpp"

#include <speex/speex_jitter.h>

#include <algorithm>
#include <cstddef>

#include "volcast/audio/opus_voice.hpp"
#include "volcast/core/error.hpp"

namespace volcast::audio {
namespace {

constexpr size_t kSlots = 100;  // 2 s of packets; the jitter buffer itself holds up to 200
constexpr auto kSpan = static_cast<spx_uint32_t>(kFrameSamples);
constexpr int32_t kRestartSamples = 5 * kSampleRate;  // a packet 5 s off the play position
constexpr int32_t kRestartPackets = 250;              // a sequence 5 s of packets back
constexpr int kMaxHoldFrames = 10;                    // 200 ms

int32_t diff(uint32_t a, uint32_t b) {
  return static_cast<int32_t>(a - b);
}

// One buffered packet. The jitter buffer holds `bytes` (JITTER_BUFFER_SET_DESTROY_CALLBACK: it
// does not copy) and hands it back from jitter_buffer_get() or to discard() when it drops it.
struct Slot {
  void* owner;  // VoiceStream::State
  bool held;
  uint32_t sequence;
  uint32_t frame;
  int64_t capture_us;
  uint32_t len;
  uint8_t bytes[kMaxOpusPacketBytes];
};

Slot* slot_of(void* bytes) {
  return reinterpret_cast<Slot*>(static_cast<char*>(bytes) - offsetof(Slot, bytes));
}

}  // namespace

struct VoiceStream::State {
  explicit State(int initial_delay_ms);
  ~State() {
    destroying = true;
    jitter_buffer_destroy(jb);
  }
  State(const State&) = delete;
  State& operator=(const State&) = delete;

  void put(uint32_t sequence, uint32_t frame, int64_t capture_us, std::span<const uint8_t> packet);
  PlayedFrame next(std::span<float, kFrameSamples> out);

  bool note_received(uint32_t sequence);
  Slot* free_slot();
  Slot* earliest_buffered() const;
  void restart(uint32_t sequence, uint32_t frame, bool new_sequence);
  int hold_frames() const;
  void resolve_gap(uint32_t sequence, uint32_t frame);
  PlayedFrame play_packet(Slot& slot, std::span<float, kFrameSamples> out);
  PlayedFrame play_missing(uint32_t timestamp, std::span<float, kFrameSamples> out);
  PlayedFrame play_insertion(uint32_t timestamp, std::span<float, kFrameSamples> out);
  PlayedFrame play_idle(std::span<float, kFrameSamples> out);
  uint32_t frame_at(uint32_t timestamp) const {
    return last_frame + static_cast<uint32_t>(diff(timestamp, last_timestamp) / int32_t{kSpan});
  }
  PlayedFrame estimate(PlayedFrame::Source source, uint32_t frame) const {
    return {source, frame, last_capture_us + int64_t{diff(frame, last_frame)} * kFrameUs};
  }

  static void discard(void* bytes) {
    Slot* slot = slot_of(bytes);
    slot->held = false;
    auto* self = static_cast<State*>(slot->owner);
    if (!self->destroying) ++self->stats.late;
  }

  JitterBuffer* jb = nullptr;
  std::unique_ptr<Slot[]> slots;
  VoiceDecoder decoder;
  VoiceStreamStats stats;
  int initial_hold = 2;
  bool destroying = false;
  bool have_base = false;  // timestamps are (frame - base_frame) * 960
  uint32_t base_frame = 0;
  bool have_highest = false;  // received sequences: the highest and a 64-bit window below it
  uint32_t highest_seq = 0;
  uint64_t window = 0;
  bool started = false;  // a packet has played
  bool synced = false;   // the jitter buffer left its reset state (a packet played since)
  bool waiting = false;  // holding playout after (re)synchronising
  int hold = 0;
  uint32_t last_seq = 0;  // the last packet played
  uint32_t last_frame = 0;
  uint32_t last_timestamp = 0;
  int64_t last_capture_us = 0;
  uint32_t since_last = 0;  // frames played since it
  uint64_t pending = 0;     // gap frames played as provisional silence
  bool talking = false;     // the last frame played was speech (packet, FEC or a lost frame)
};

VoiceStream::State::State(int initial_delay_ms)
    : jb(jitter_buffer_init(static_cast<int>(kSpan))), slots(std::make_unique<Slot[]>(kSlots)) {
  if (jb == nullptr) throw Error("jitter_buffer_init failed");
  if (initial_delay_ms < 0 || initial_delay_ms > 1000) {
    jitter_buffer_destroy(jb);
    throw Error("voice stream: initial delay " + std::to_string(initial_delay_ms) +
                " ms is outside 0..1000");
  }
  initial_hold = (initial_delay_ms + 19) / 20;
  void (*callback)(void*) = &State::discard;
  jitter_buffer_ctl(jb, JITTER_BUFFER_SET_DESTROY_CALLBACK, reinterpret_cast<void*>(callback));
  // The share of packets the buffer lets arrive too late (speexdsp's default: 4 %): 1 % keeps
  // enough delay for TCP's retransmissions on a lossy path (tests/voice: the impaired path).
  spx_int32_t late_rate = 1;
  jitter_buffer_ctl(jb, JITTER_BUFFER_SET_MAX_LATE_RATE, &late_rate);
  for (size_t i = 0; i < kSlots; ++i) {
    slots[i].owner = this;
    slots[i].held = false;
  }
}

bool VoiceStream::State::note_received(uint32_t sequence) {
  if (!have_highest) {
    have_highest = true;
    highest_seq = sequence;
    window = 1;
    return true;
  }
  const int32_t d = diff(sequence, highest_seq);
  if (d > 0) {
    window = d >= 64 ? 0 : window << d;
    window |= 1;
    highest_seq = sequence;
    return true;
  }
  const auto back = static_cast<uint32_t>(-static_cast<int64_t>(d));
  if (back >= 64) {
    ++stats.late;
    return false;
  }
  if ((window & (uint64_t{1} << back)) != 0) {
    ++stats.duplicates;
    return false;
  }
  window |= uint64_t{1} << back;
  return true;
}

Slot* VoiceStream::State::free_slot() {
  for (size_t i = 0; i < kSlots; ++i) {
    if (!slots[i].held) return &slots[i];
  }
  return nullptr;
}

Slot* VoiceStream::State::earliest_buffered() const {
  Slot* best = nullptr;
  for (size_t i = 0; i < kSlots; ++i) {
    Slot& s = slots[i];
    if (s.held && diff(s.sequence, last_seq) > 0 &&
        (best == nullptr || diff(s.sequence, best->sequence) < 0)) {
      best = &s;
    }
  }
  return best;
}

int VoiceStream::State::hold_frames() const {
  return std::clamp(std::max(initial_hold, (stats.delay_ms + 19) / 20), 0, kMaxHoldFrames);
}

// Resynchronises on a packet far off the play position: the sender restarted (its sequence went
// back: start counting afresh) or its frame clock jumped.
void VoiceStream::State::restart(uint32_t sequence, uint32_t frame, bool new_sequence) {
  jitter_buffer_reset(jb);  // discards what it holds (counted late)
  base_frame = frame;
  synced = false;
  waiting = false;
  if (new_sequence) {
    have_highest = false;
    last_seq = sequence - 1;
    last_frame = frame - 1;
    pending = 0;
  }
}

void VoiceStream::State::put(uint32_t sequence, uint32_t frame, int64_t capture_us,
                             std::span<const uint8_t> packet) {
  if (!is_voice_packet(packet)) {
    ++stats.malformed;
    return;
  }
  ++stats.packets;
  if (have_highest && diff(sequence, highest_seq) < -kRestartPackets) {
    restart(sequence, frame, true);
  }
  if (!note_received(sequence)) return;
  if (started && diff(sequence, last_seq) <= 0) {
    ++stats.late;  // its place was played already
    return;
  }
  if (!have_base) {
    have_base = true;
    base_frame = frame;
  }
  uint32_t ts = (frame - base_frame) * kSpan;
  const auto pointer = static_cast<uint32_t>(jitter_buffer_get_pointer_timestamp(jb));
  if (synced) {
    const int32_t ahead = diff(ts, pointer);
    if (ahead < -kRestartSamples || ahead > kRestartSamples) {
      restart(sequence, frame, false);
      ts = 0;
    } else if (diff(ts + kSpan, pointer) < 0) {
      ++stats.late;  // the jitter buffer would not take it (jitter.c: hopelessly late)
      return;
    }
  }
  Slot* slot = free_slot();
  if (slot == nullptr) {
    ++stats.late;  // buffer full (a sender far ahead of its play position)
    return;
  }
  slot->held = true;
  slot->sequence = sequence;
  slot->frame = frame;
  slot->capture_us = capture_us;
  slot->len = static_cast<uint32_t>(packet.size());
  std::copy(packet.begin(), packet.end(), slot->bytes);
  JitterBufferPacket p{};
  p.data = reinterpret_cast<char*>(slot->bytes);
  p.len = slot->len;
  p.timestamp = ts;
  p.span = kSpan;
  p.sequence = static_cast<spx_uint16_t>(sequence);
  const auto before = static_cast<uint32_t>(jitter_buffer_get_pointer_timestamp(jb));
  jitter_buffer_put(jb, &p);
  if (synced && static_cast<uint32_t>(jitter_buffer_get_pointer_timestamp(jb)) != before) {
    synced = false;  // jitter.c reset itself (> 20 frames missing, as after a DTX pause)
  }
  if (!synced && !waiting) {
    waiting = true;
    hold = hold_frames();
  }
  if (sequence == highest_seq && synced) {
    const auto play_at = static_cast<uint32_t>(jitter_buffer_get_pointer_timestamp(jb));
    stats.delay_ms = std::max(0, diff(ts, play_at)) / (kSampleRate / 1000);
  } else if (!synced) {
    stats.delay_ms = hold * 20;
  }
}

void VoiceStream::State::resolve_gap(uint32_t sequence, uint32_t frame) {
  const int32_t ds = diff(sequence, last_seq);
  const int32_t df = diff(frame, last_frame);
  if (ds > 0 && df > 0) {
    const auto lost = static_cast<uint64_t>(std::min(ds - 1, df - 1));
    stats.lost += lost;
    const uint64_t moved = std::min({pending, lost, stats.frames_silent});
    stats.frames_silent -= moved;
    stats.frames_concealed += moved;
  }
  pending = 0;
}

PlayedFrame VoiceStream::State::play_packet(Slot& slot, std::span<float, kFrameSamples> out) {
  slot.held = false;  // the jitter buffer handed it back
  synced = true;
  if (started) resolve_gap(slot.sequence, slot.frame);
  PlayedFrame::Source source = PlayedFrame::Source::kPacket;
  try {
    decoder.decode({slot.bytes, slot.len}, out);
    ++stats.frames_from_packets;
  } catch (const Error&) {  // checked at put(); libopus may still reject its inner structure
    decoder.conceal(out);
    ++stats.frames_concealed;
    source = PlayedFrame::Source::kConcealed;
  }
  if (!started || diff(slot.sequence, last_seq) > 0) last_seq = slot.sequence;
  started = true;
  talking = true;
  last_frame = slot.frame;
  last_capture_us = slot.capture_us;
  since_last = 0;
  return {source, slot.frame, slot.capture_us};
}

PlayedFrame VoiceStream::State::play_idle(std::span<float, kFrameSamples> out) {
  ++stats.frames_silent;
  if (!started) {
    std::fill(out.begin(), out.end(), 0.0f);
    return {PlayedFrame::Source::kSilence, 0, 0};
  }
  decoder.conceal(out);  // fades into comfort noise
  ++pending;
  ++since_last;
  talking = false;
  return estimate(PlayedFrame::Source::kSilence, last_frame + since_last);
}

PlayedFrame VoiceStream::State::play_missing(uint32_t timestamp,
                                             std::span<float, kFrameSamples> out) {
  if (!started) return play_idle(out);
  const uint32_t frame = frame_at(timestamp);
  const int32_t k = diff(frame, last_frame);  // 1 for the first frame of the gap
  ++since_last;
  if (const Slot* next = earliest_buffered()) {
    const int32_t lost =
        std::min(diff(next->sequence, last_seq), diff(next->frame, last_frame)) - 1;
    if (k >= 1 && k <= lost) {
      talking = true;
      if (diff(next->frame, frame) == 1) {
        decoder.decode_fec({next->bytes, next->len}, out);
        ++stats.frames_fec;
        return estimate(PlayedFrame::Source::kFec, frame);
      }
      decoder.conceal(out);
      ++stats.frames_concealed;
      return estimate(PlayedFrame::Source::kConcealed, frame);
    }
  } else {
    ++pending;  // fate unknown until the next packet plays
  }
  decoder.conceal(out);  // the end of a talk spurt (DTX), or not known yet
  talking = false;
  ++stats.frames_silent;
  return estimate(PlayedFrame::Source::kSilence, frame);
}

PlayedFrame VoiceStream::State::play_insertion(uint32_t timestamp,
                                               std::span<float, kFrameSamples> out) {
  if (!started) return play_idle(out);
  decoder.conceal(out);
  ++since_last;
  const uint32_t frame = frame_at(timestamp);
  if (talking) {
    ++stats.frames_concealed;
    return estimate(PlayedFrame::Source::kConcealed, frame);
  }
  ++stats.frames_silent;
  return estimate(PlayedFrame::Source::kSilence, frame);
}

PlayedFrame VoiceStream::State::next(std::span<float, kFrameSamples> out) {
  ++stats.frames_played;
  if (waiting && hold > 0) {
    --hold;
    return play_idle(out);
  }
  waiting = false;
  JitterBufferPacket p{};
  spx_int32_t offset = 0;
  const int rc = jitter_buffer_get(jb, &p, static_cast<spx_int32_t>(kSpan), &offset);
  PlayedFrame played;
  if (rc == JITTER_BUFFER_OK) {
    Slot* slot = slot_of(p.data);
    played = play_packet(*slot, out);
    last_timestamp = p.timestamp;
  } else if (!synced) {
    played = play_idle(out);
  } else if (rc == JITTER_BUFFER_INSERTION) {
    played = play_insertion(p.timestamp, out);
  } else {
    played = play_missing(p.timestamp, out);
  }
  jitter_buffer_tick(jb);
  return played;
}

VoiceStream::VoiceStream(int initial_delay_ms)
    : state_(std::make_unique<State>(initial_delay_ms)) {}
VoiceStream::~VoiceStream() = default;
VoiceStream::VoiceStream(VoiceStream&&) noexcept = default;
VoiceStream& VoiceStream::operator=(VoiceStream&&) noexcept = default;

void VoiceStream::put(uint32_t sequence, uint32_t frame, int64_t capture_us,
                      std::span<const uint8_t> packet) {
  state_->put(sequence, frame, capture_us, packet);
}

PlayedFrame VoiceStream::next(std::span<float, kFrameSamples> out) {
  return state_->next(out);
}

VoiceStreamStats VoiceStream::stats() const {
  return state_->stats;
}

}  // namespace volcast::audio
