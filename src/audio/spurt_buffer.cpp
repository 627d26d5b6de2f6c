// VoiceStream's default playout buffer: plays by frame number and changes its delay only where no
// one hears it (a talk spurt's start, a quiet frame). See voice_stream.hpp for the rules.
//
// Times are counted in next() calls ("ticks"). A packet of frame f put before the next() call of
// tick a arrived at offset o = f - a. next() at tick T plays frame T + base, so the packet is on
// time when o >= base: the largest base that lets at most p % of the recent packets be late is
// the p-th percentile of their offsets (the buffer's target). A smaller base is a longer delay.
#include <algorithm>
#include <cmath>

#include "voice_stream_parts.hpp"

namespace volcast::audio::detail {
namespace {

constexpr uint32_t kSlots = 100;         // 2 s of frames, a packet at slot frame % kSlots
constexpr size_t kHistory = 500;         // offsets of the last 10 s of talk
constexpr size_t kWarm = 50;             // fewer offsets known: one frame more delay
constexpr int32_t kRestartFrames = 250;  // a packet 5 s behind the play position
constexpr int32_t kMaxOverMedian = 10;   // the delay exceeds the median packet's by <= 200 ms
constexpr float kQuietFloor = 1e-3f;     // -60 dBFS RMS
constexpr float kQuietRatio = 0.1f;      // 20 dB under the recent level
constexpr float kLevelDecay = 0.98f;     // per frame: the level falls 20 dB in 2.3 s
constexpr int32_t kMaxStall = 50;        // frames: a stalled stream resumes, and a talk spurt
                                         // starts, at most 1 s late
constexpr uint32_t kLongSpurt = 150;     // frames (3 s): a spurt this long may shrink the delay

class SpurtBuffer final : public Buffer {
 public:
  explicit SpurtBuffer(const VoiceStreamConfig& config)
      : slots_(std::make_unique<Slot[]>(kSlots)),
        history_(std::make_unique<int32_t[]>(kHistory)),
        sorted_(std::make_unique<int32_t[]>(kHistory)),
        initial_hold_(static_cast<uint32_t>((config.initial_delay_ms + 19) / 20)),
        late_percent_(static_cast<size_t>(config.max_late_percent)) {}

  void put(uint32_t sequence, uint32_t frame, int64_t capture_us,
           std::span<const uint8_t> packet) override;
  PlayedFrame next(std::span<float, kFrameSamples> out) override;
  void hold() override {  // the clock runs on, the play position waits: one block more delay
    ++player_.stats.frames_held;
    ++tick_;
  }
  const VoiceStreamStats& stats() const override { return player_.stats; }

 private:
  Slot& slot_for(uint32_t frame) const { return slots_[frame % kSlots]; }
  Slot* buffered(uint32_t frame) const {
    Slot& s = slot_for(frame);
    return s.held && s.frame == frame ? &s : nullptr;
  }
  const Slot* earliest_from(uint32_t frame) const {
    for (uint32_t i = 0; i < kSlots; ++i)
      if (const Slot* s = buffered(frame + i)) return s;
    return nullptr;
  }
  int32_t base() const { return diff(play_frame_, tick_); }
  void restart(uint32_t sequence, uint32_t frame);
  void remember(int32_t offset);
  int32_t target();
  void start_spurt();
  bool quiet(std::span<const float, kFrameSamples> frame);
  PlayedFrame play(Slot& slot, std::span<float, kFrameSamples> out);

  std::unique_ptr<Slot[]> slots_;
  std::unique_ptr<int32_t[]> history_;  // a ring of the last kHistory offsets
  std::unique_ptr<int32_t[]> sorted_;   // scratch for the percentiles
  size_t history_size_ = 0;
  size_t history_at_ = 0;
  bool target_known_ = false;
  int32_t target_ = 0;
  VoicePlayer player_;
  SequenceWindow window_;
  uint32_t initial_hold_;
  size_t late_percent_;
  bool anchored_ = false;      // play_frame_ is set (a packet arrived)
  bool resync_ = true;         // the next packet starts a spurt whatever its sequence says
  uint32_t play_frame_ = 0;    // the frame the next next() plays
  uint32_t tick_ = 0;          // next() calls so far
  bool insert_ = false;        // the next next() inserts a quiet frame
  bool last_quiet_ = false;    // the last frame played was a quiet packet
  uint32_t spurt_frames_ = 0;  // packets played since the talk spurt started
  float level_ = 0;            // the recent speech level: a decaying peak of frame RMS
};

void SpurtBuffer::restart(uint32_t sequence, uint32_t frame) {
  for (uint32_t i = 0; i < kSlots; ++i) {
    if (slots_[i].held) ++player_.stats.late;
    slots_[i].held = false;
  }
  history_size_ = history_at_ = 0;
  target_known_ = false;
  anchored_ = false;
  resync_ = true;
  insert_ = last_quiet_ = false;
  level_ = 0;
  window_ = {};
  player_.restart_sequence(sequence, frame);
}

void SpurtBuffer::remember(int32_t offset) {
  history_[history_at_] = offset;
  history_at_ = (history_at_ + 1) % kHistory;
  history_size_ = std::min(history_size_ + 1, kHistory);
  target_known_ = false;
}

int32_t SpurtBuffer::target() {
  if (history_size_ == 0) return base();
  if (!target_known_) {
    const size_t n = history_size_;
    std::copy(history_.get(), history_.get() + n, sorted_.get());
    int32_t* first = sorted_.get();
    const size_t k = n * late_percent_ / 100;
    std::nth_element(first, first + k, first + n);
    const int32_t percentile = first[k];
    std::nth_element(first, first + n / 2, first + n);
    const int32_t median = first[n / 2];
    target_ = n < kWarm ? percentile - 1 : percentile;
    target_ = std::max(target_, median - kMaxOverMedian);
    target_known_ = true;
  }
  return target_;
}

void SpurtBuffer::put(uint32_t sequence, uint32_t frame, int64_t capture_us,
                      std::span<const uint8_t> packet) {
  VoiceStreamStats& stats = player_.stats;
  if (!is_voice_packet(packet)) {
    ++stats.malformed;
    return;
  }
  ++stats.packets;
  if (window_.restarted(sequence)) restart(sequence, frame);
  if (!window_.note(sequence, stats)) return;
  if (anchored_) {
    const int32_t ahead = diff(frame, play_frame_);
    if (ahead < -kRestartFrames || ahead >= int32_t{kSlots}) {
      restart(sequence, frame);  // the sender's frame clock jumped
      window_.note(sequence, stats);
    }
  }
  remember(diff(frame, tick_));
  if (anchored_ && player_.started && sequence == player_.last_seq + 1 &&
      diff(frame, play_frame_) < 0) {
    // The packet after the last one played, late: the stream stalled (TCP retransmitting, a
    // loaded machine's thread not run) and only concealment or silence has played since.
    const int32_t behind = diff(play_frame_, frame);
    if (frame == player_.last_frame + 1 && behind <= kMaxStall) {
      // Inside a talk spurt: resume where it stopped, the stall heard as a pause, rather than
      // lose what is held up behind it; decoded as if the concealment had not played
      // (VoicePlayer::resume).
      player_.resume();
      play_frame_ = frame;
    } else if (diff(frame, player_.last_frame) > 1 && !player_.talking && behind <= kMaxStall) {
      // The first packet of a talk spurt (after DTX): the spurt starts late, the silence before
      // it stretched by the frames already played as silence in its place, rather than lose its
      // first words (start_spurt places it at the next next()).
      player_.stats.frames_inserted += static_cast<uint64_t>(behind);
      play_frame_ = frame;
    }
  }
  if ((player_.started && diff(sequence, player_.last_seq) <= 0) ||
      (anchored_ && diff(frame, play_frame_) < 0)) {
    ++stats.late;  // its place was played already
    return;
  }
  Slot& slot = slot_for(frame);
  if (slot.held) {
    if (slot.frame == frame) {
      ++stats.duplicates;  // another packet for the same frame
      return;
    }
    ++stats.late;  // (not expected: a packet left behind the play position)
  }
  slot.held = true;
  slot.sequence = sequence;
  slot.frame = frame;
  slot.capture_us = capture_us;
  slot.len = static_cast<uint32_t>(packet.size());
  std::copy(packet.begin(), packet.end(), slot.bytes);
  if (!anchored_) {
    anchored_ = true;
    play_frame_ = frame - initial_hold_;
  }
  if (sequence == window_.highest)
    stats.delay_ms = std::max(0, diff(frame, play_frame_)) * (kFrameUs / 1000);
}

// In silence: if the earliest buffered packet opens a new talk spurt (its sequence follows the
// last one played, after a DTX gap), move the play position so that the spurt plays at the
// target delay, the silence before it stretched or cut. Never past the spurt's first frame,
// never back onto a frame played.
void SpurtBuffer::start_spurt() {
  const Slot* first = earliest_from(play_frame_);
  if (first == nullptr) return;
  const bool new_spurt = resync_ || (first->sequence == player_.last_seq + 1 &&
                                     diff(first->frame, player_.last_frame) > 1);
  if (!new_spurt) return;  // a lost or late packet inside a spurt: played where it was due
  uint32_t frame = tick_ + static_cast<uint32_t>(target());
  if (diff(frame, first->frame - initial_hold_) > 0) frame = first->frame - initial_hold_;
  if (player_.started && diff(frame, player_.last_frame) <= 0) frame = player_.last_frame + 1;
  play_frame_ = frame;
  spurt_frames_ = 0;
}

bool SpurtBuffer::quiet(std::span<const float, kFrameSamples> frame) {
  float energy = 0;
  for (const float x : frame) energy += x * x;
  const float rms = std::sqrt(energy / static_cast<float>(kFrameSamples));
  level_ = std::max(rms, level_ * kLevelDecay);
  return rms < kQuietFloor || rms < kQuietRatio * level_;
}

// Plays `slot` (frame play_frame_); across quiet frames, drops one to shrink the delay or sets
// up an insertion to grow it, as the target asks.
PlayedFrame SpurtBuffer::play(Slot& slot, std::span<float, kFrameSamples> out) {
  Slot* s = &slot;
  bool decoded = player_.decode(*s, out);
  s->held = false;
  bool is_quiet = quiet(out);
  // Shrink inside a spurt only in a long one (a microphone that never falls silent); else at the
  // next spurt's start.
  if (is_quiet && last_quiet_ && spurt_frames_ >= kLongSpurt && target() > base()) {
    if (Slot* after = buffered(s->frame + 1)) {  // drop this quiet frame, play the next
      player_.skipped(*s);
      ++play_frame_;
      s = after;
      decoded = player_.decode(*s, out);
      s->held = false;
      is_quiet = quiet(out);
    }
  }
  const PlayedFrame played = player_.played(*s, decoded);
  ++spurt_frames_;
  insert_ = is_quiet && target() < base();
  last_quiet_ = is_quiet;
  return played;
}

PlayedFrame SpurtBuffer::next(std::span<float, kFrameSamples> out) {
  ++player_.stats.frames_played;
  PlayedFrame played;
  if (!anchored_) {
    played = player_.play_idle(out);
  } else if (insert_) {
    insert_ = false;
    last_quiet_ = true;
    played = player_.play_insertion(play_frame_ - 1, false, out);
    --play_frame_;  // the same frame is due again at the next tick: one frame more delay
  } else {
    if (!player_.talking) start_spurt();
    if (Slot* slot = buffered(play_frame_)) {
      played = play(*slot, out);
      resync_ = false;
    } else {
      played = player_.play_missing(play_frame_, earliest_from(play_frame_ + 1), out);
      last_quiet_ = false;
    }
  }
  ++play_frame_;
  ++tick_;
  return played;
}

}  // namespace

std::unique_ptr<Buffer> make_spurt_buffer(const VoiceStreamConfig& config) {
  return std::make_unique<SpurtBuffer>(config);
}

}  // namespace volcast::audio::detail
