// VoiceStream's baseline playout buffer: speexdsp's adaptive jitter buffer (speex/speex_jitter.h,
// timestamps in samples: (frame - base frame) * 960). See voice_stream.hpp.
#include <speex/speex_jitter.h>

#include <algorithm>
#include <cstddef>

#include "voice_stream_parts.hpp"
#include "volcast/core/error.hpp"

namespace volcast::audio::detail {
namespace {

constexpr size_t kSlots = 100;  // 2 s of packets; the jitter buffer itself holds up to 200
constexpr auto kSpan = static_cast<spx_uint32_t>(kFrameSamples);
constexpr int32_t kRestartSamples = 5 * kSampleRate;  // a packet 5 s off the play position
constexpr int kMaxHoldFrames = 10;                    // 200 ms

// The jitter buffer holds a Slot's `bytes` (JITTER_BUFFER_SET_DESTROY_CALLBACK: it does not
// copy) and hands it back from jitter_buffer_get() or to discard() when it drops it.
Slot* slot_of(void* bytes) {
  return reinterpret_cast<Slot*>(static_cast<char*>(bytes) - offsetof(Slot, bytes));
}

class SpeexdspBuffer final : public Buffer {
 public:
  explicit SpeexdspBuffer(const VoiceStreamConfig& config);
  ~SpeexdspBuffer() override {
    destroying_ = true;
    jitter_buffer_destroy(jb_);
  }
  SpeexdspBuffer(const SpeexdspBuffer&) = delete;
  SpeexdspBuffer& operator=(const SpeexdspBuffer&) = delete;

  void put(uint32_t sequence, uint32_t frame, int64_t capture_us,
           std::span<const uint8_t> packet) override;
  PlayedFrame next(std::span<float, kFrameSamples> out) override;
  void hold() override {  // no pause in speexdsp: the frame due is played into nothing
    next(scratch_);
    --player_.stats.frames_played;
    ++player_.stats.frames_held;
  }
  const VoiceStreamStats& stats() const override { return player_.stats; }

 private:
  Slot* free_slot();
  Slot* earliest_buffered() const;
  void restart(uint32_t sequence, uint32_t frame, bool new_sequence);
  int hold_frames() const {
    return std::clamp(std::max(initial_hold_, (player_.stats.delay_ms + 19) / 20), 0,
                      kMaxHoldFrames);
  }
  uint32_t frame_at(uint32_t timestamp) const {
    return player_.last_frame +
           static_cast<uint32_t>(diff(timestamp, last_timestamp_) / int32_t{kSpan});
  }
  static void discard(void* bytes) {
    Slot* slot = slot_of(bytes);
    slot->held = false;
    auto* self = static_cast<SpeexdspBuffer*>(slot->owner);
    if (!self->destroying_) ++self->player_.stats.late;
  }

  JitterBuffer* jb_ = nullptr;
  std::unique_ptr<Slot[]> slots_;
  std::array<float, kFrameSamples> scratch_{};  // hold()'s frame, heard by nobody
  VoicePlayer player_;
  SequenceWindow window_;
  int initial_hold_ = 0;
  bool destroying_ = false;
  bool have_base_ = false;  // timestamps are (frame - base_frame) * 960
  uint32_t base_frame_ = 0;
  bool synced_ = false;   // the jitter buffer left its reset state (a packet played since)
  bool waiting_ = false;  // holding playout after (re)synchronising
  int hold_ = 0;
  uint32_t last_timestamp_ = 0;
};

SpeexdspBuffer::SpeexdspBuffer(const VoiceStreamConfig& config)
    : jb_(jitter_buffer_init(static_cast<int>(kSpan))), slots_(std::make_unique<Slot[]>(kSlots)) {
  if (jb_ == nullptr) throw Error("jitter_buffer_init failed");
  initial_hold_ = (config.initial_delay_ms + 19) / 20;
  void (*callback)(void*) = &SpeexdspBuffer::discard;
  jitter_buffer_ctl(jb_, JITTER_BUFFER_SET_DESTROY_CALLBACK, reinterpret_cast<void*>(callback));
  // The share of packets the buffer lets arrive too late (speexdsp's default: 4 %).
  spx_int32_t late_rate = config.max_late_percent;
  jitter_buffer_ctl(jb_, JITTER_BUFFER_SET_MAX_LATE_RATE, &late_rate);
  for (size_t i = 0; i < kSlots; ++i) slots_[i].owner = this;
}

Slot* SpeexdspBuffer::free_slot() {
  for (size_t i = 0; i < kSlots; ++i) {
    if (!slots_[i].held) return &slots_[i];
  }
  return nullptr;
}

Slot* SpeexdspBuffer::earliest_buffered() const {
  Slot* best = nullptr;
  for (size_t i = 0; i < kSlots; ++i) {
    Slot& s = slots_[i];
    if (s.held && diff(s.sequence, player_.last_seq) > 0 &&
        (best == nullptr || diff(s.sequence, best->sequence) < 0)) {
      best = &s;
    }
  }
  return best;
}

// Resynchronises on a packet far off the play position: the sender restarted (its sequence went
// back: start counting afresh) or its frame clock jumped.
void SpeexdspBuffer::restart(uint32_t sequence, uint32_t frame, bool new_sequence) {
  jitter_buffer_reset(jb_);  // discards what it holds (counted late)
  base_frame_ = frame;
  synced_ = false;
  waiting_ = false;
  if (new_sequence) {
    window_ = {};
    player_.restart_sequence(sequence, frame);
  }
}

void SpeexdspBuffer::put(uint32_t sequence, uint32_t frame, int64_t capture_us,
                         std::span<const uint8_t> packet) {
  VoiceStreamStats& stats = player_.stats;
  if (!is_voice_packet(packet)) {
    ++stats.malformed;
    return;
  }
  ++stats.packets;
  if (window_.restarted(sequence)) restart(sequence, frame, true);
  if (!window_.note(sequence, stats)) return;
  if (player_.started && diff(sequence, player_.last_seq) <= 0) {
    ++stats.late;  // its place was played already
    return;
  }
  if (!have_base_) {
    have_base_ = true;
    base_frame_ = frame;
  }
  uint32_t ts = (frame - base_frame_) * kSpan;
  const auto pointer = static_cast<uint32_t>(jitter_buffer_get_pointer_timestamp(jb_));
  if (synced_) {
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
  const auto before = static_cast<uint32_t>(jitter_buffer_get_pointer_timestamp(jb_));
  jitter_buffer_put(jb_, &p);
  if (synced_ && static_cast<uint32_t>(jitter_buffer_get_pointer_timestamp(jb_)) != before) {
    synced_ = false;  // jitter.c reset itself (> 20 frames missing, as after a DTX pause)
  }
  if (!synced_ && !waiting_) {
    waiting_ = true;
    hold_ = hold_frames();
  }
  if (sequence == window_.highest && synced_) {
    const auto play_at = static_cast<uint32_t>(jitter_buffer_get_pointer_timestamp(jb_));
    stats.delay_ms = std::max(0, diff(ts, play_at)) / (kSampleRate / 1000);
  } else if (!synced_) {
    stats.delay_ms = hold_ * 20;
  }
}

PlayedFrame SpeexdspBuffer::next(std::span<float, kFrameSamples> out) {
  ++player_.stats.frames_played;
  if (waiting_ && hold_ > 0) {
    --hold_;
    return player_.play_idle(out);
  }
  waiting_ = false;
  JitterBufferPacket p{};
  spx_int32_t offset = 0;
  const int rc = jitter_buffer_get(jb_, &p, static_cast<spx_int32_t>(kSpan), &offset);
  PlayedFrame played;
  if (rc == JITTER_BUFFER_OK) {
    Slot* slot = slot_of(p.data);
    slot->held = false;  // the jitter buffer handed it back
    synced_ = true;
    played = player_.play_packet(*slot, out);
    last_timestamp_ = p.timestamp;
  } else if (!synced_) {
    played = player_.play_idle(out);
  } else if (rc == JITTER_BUFFER_INSERTION) {
    played = player_.play_insertion(frame_at(p.timestamp), player_.talking, out);
  } else {
    played = player_.play_missing(frame_at(p.timestamp), earliest_buffered(), out);
  }
  jitter_buffer_tick(jb_);
  return played;
}

}  // namespace

std::unique_ptr<Buffer> make_speexdsp_buffer(const VoiceStreamConfig& config) {
  return std::make_unique<SpeexdspBuffer>(config);
}

}  // namespace volcast::audio::detail
