#include "volcast/audio/voice_stream.hpp"

#include <algorithm>
#include <string>

#include "voice_stream_parts.hpp"
#include "volcast/core/error.hpp"

namespace volcast::audio {
namespace detail {

bool SequenceWindow::note(uint32_t sequence, VoiceStreamStats& stats) {
  if (!have) {
    have = true;
    highest = sequence;
    bits = 1;
    return true;
  }
  const int32_t d = diff(sequence, highest);
  if (d > 0) {
    bits = d >= 64 ? 0 : bits << d;
    bits |= 1;
    highest = sequence;
    return true;
  }
  const auto back = static_cast<uint32_t>(-static_cast<int64_t>(d));
  if (back >= 64) {
    ++stats.late;
    return false;
  }
  if ((bits & (uint64_t{1} << back)) != 0) {
    ++stats.duplicates;
    return false;
  }
  bits |= uint64_t{1} << back;
  return true;
}

void VoicePlayer::resume() {
  stats.frames_inserted += pending;
  pending = 0;
  if (since_last > 0) decoder.restore();
}

void VoicePlayer::restart_sequence(uint32_t sequence, uint32_t frame) {
  last_seq = sequence - 1;
  last_frame = frame - 1;
  pending = 0;
  talking = false;
}

void VoicePlayer::resolve_gap(uint32_t sequence, uint32_t frame) {
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

bool VoicePlayer::decode(const Slot& slot, std::span<float, kFrameSamples> out) {
  try {
    decoder.decode({slot.bytes, slot.len}, out);
    return true;
  } catch (const Error&) {  // checked at put(); libopus may still reject its inner structure
    decoder.conceal(out);
    return false;
  }
}

void VoicePlayer::advance(const Slot& slot) {
  if (started) resolve_gap(slot.sequence, slot.frame);
  if (!started || diff(slot.sequence, last_seq) > 0) last_seq = slot.sequence;
  started = true;
  last_frame = slot.frame;
  last_capture_us = slot.capture_us;
  since_last = 0;
}

PlayedFrame VoicePlayer::played(const Slot& slot, bool decoded) {
  advance(slot);
  talking = true;
  if (!decoded) {
    ++stats.frames_concealed;
    return {PlayedFrame::Source::kConcealed, slot.frame, slot.capture_us};
  }
  ++stats.frames_from_packets;
  return {PlayedFrame::Source::kPacket, slot.frame, slot.capture_us};
}

void VoicePlayer::skipped(const Slot& slot) {
  advance(slot);
  ++stats.frames_skipped;
}

PlayedFrame VoicePlayer::play_idle(std::span<float, kFrameSamples> out) {
  ++stats.frames_silent;
  if (!started) {
    std::fill(out.begin(), out.end(), 0.0f);
    return {PlayedFrame::Source::kSilence, 0, 0};
  }
  left_packet();
  decoder.conceal(out);  // fades into comfort noise
  ++pending;
  talking = false;
  return estimate(PlayedFrame::Source::kSilence, last_frame + since_last);
}

PlayedFrame VoicePlayer::play_missing(uint32_t frame, const Slot* next,
                                      std::span<float, kFrameSamples> out) {
  if (!started) return play_idle(out);
  const int32_t k = diff(frame, last_frame);  // 1 for the first frame of the gap
  left_packet();
  if (next != nullptr) {
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

PlayedFrame VoicePlayer::play_insertion(uint32_t frame, bool as_speech,
                                        std::span<float, kFrameSamples> out) {
  if (!started) return play_idle(out);
  left_packet();
  decoder.conceal(out);
  if (as_speech) {
    ++stats.frames_concealed;
    return estimate(PlayedFrame::Source::kConcealed, frame);
  }
  ++stats.frames_silent;
  ++stats.frames_inserted;
  return estimate(PlayedFrame::Source::kSilence, frame);
}

}  // namespace detail

PlayoutKind parse_playout_kind(std::string_view text) {
  if (text == "spurt") return PlayoutKind::kSpurt;
  if (text == "speexdsp") return PlayoutKind::kSpeexdsp;
  throw Error("unknown jitter buffer '" + std::string(text) + "' (spurt or speexdsp)");
}

const char* to_string(PlayoutKind kind) {
  return kind == PlayoutKind::kSpeexdsp ? "speexdsp" : "spurt";
}

VoiceStream::VoiceStream(const VoiceStreamConfig& config) {
  if (config.initial_delay_ms < 0 || config.initial_delay_ms > 1000)
    throw Error("voice stream: initial delay " + std::to_string(config.initial_delay_ms) +
                " ms is outside 0..1000");
  if (config.max_late_percent < 0 || config.max_late_percent > 50)
    throw Error("voice stream: late share " + std::to_string(config.max_late_percent) +
                " % is outside 0..50");
  buffer_ = config.playout == PlayoutKind::kSpeexdsp ? detail::make_speexdsp_buffer(config)
                                                     : detail::make_spurt_buffer(config);
}
VoiceStream::~VoiceStream() = default;
VoiceStream::VoiceStream(VoiceStream&&) noexcept = default;
VoiceStream& VoiceStream::operator=(VoiceStream&&) noexcept = default;

void VoiceStream::put(uint32_t sequence, uint32_t frame, int64_t capture_us,
                      std::span<const uint8_t> packet) {
  buffer_->put(sequence, frame, capture_us, packet);
}

PlayedFrame VoiceStream::next(std::span<float, kFrameSamples> out) {
  return buffer_->next(out);
}

void VoiceStream::hold() {
  buffer_->hold();
}

VoiceStreamStats VoiceStream::stats() const {
  return buffer_->stats();
}

}  // namespace volcast::audio
