#pragma once
// One speaker's incoming voice at a receiver: a playout (jitter) buffer in front of a
// VoiceDecoder, with Opus in-band FEC when a packet is missing but the next one is there, PLC
// (comfort noise after DTX) otherwise. put() is called as packets arrive, next() once per 20 ms of
// the playout clock; arrival times are counted in next() calls.
//
// Packets carry `sequence` (+1 per packet sent) and `frame` (+1 per 20 ms frame captured, sent
// or not: DTX skips frames). A gap between two played packets of `sequence` s -> s' and `frame`
// f -> f' holds G = f' - f - 1 frames of which L = min(s' - s - 1, G) packets were lost. Rule:
// the lost ones are the first L frames of the gap (a talk spurt goes on, then the speaker falls
// silent); the other G - L frames were DTX silence.
//
// When a frame is due and its packet is missing:
//  - if a later packet is already buffered, the rule above labels the frame now: lost -> kFec
//    (the next frame's packet is buffered: its in-band FEC) or kConcealed (PLC); DTX -> kSilence;
//  - if none is (the speaker stopped talking, or a burst was lost), the frame is played with PLC
//    (which fades into comfort noise) and returned as kSilence, provisionally: when the next
//    packet is played, the rule is applied to these frames and stats() moves the lost ones from
//    frames_silent to frames_concealed. Counts are therefore final once the next packet plays.
// Before the first packet, frames are silence (zeros), kSilence.
//
// Two playout buffers (VoiceStreamConfig::playout); both play by the sender's frame number, so a
// silence inside a talk spurt keeps its length:
//  - kSpurt (the default, Volcast's own): the delay is chosen from the arrival offsets of the
//    last 500 packets (10 s of talk): the least delay that would have let at most
//    `max_late_percent` of them arrive too late (one frame more while fewer than 50 are known,
//    at most 200 ms more than the median packet waits). The delay changes only where no one
//    hears it: at a talk spurt's start (the silence before it is stretched or cut, never its
//    first frame), and inside a spurt only across a quiet frame (20 dB under the spurt's recent
//    level, or under -60 dBFS): one quiet frame inserted (kSilence, counted in frames_inserted)
//    to grow, one quiet packet decoded but not played (frames_skipped) to shrink (inside a
//    spurt only after 3 s of talk: a microphone that never falls silent). A stalled stream (TCP
//    holding packets behind a retransmission: the packet after the last one played arrives after
//    its time, up to 1 s late: a loaded sender or path, as NetEq plays on in sequence) is resumed
//    where it stopped, the stall heard as a pause (its frames counted in frames_inserted), instead
//    of losing what was held up; the rest of the spurt plays that much later, and the next
//    spurt's start gives the delay back. A talk spurt whose
//    first packet arrives after its time (the stream stalled in the silence before it), up to 1 s
//    late, starts late: the silence is stretched (the frames already played as silence in its
//    place counted in frames_inserted) rather than its first words lost. Other late packets are
//    counted and concealed where they were due.
//  - kSpeexdsp: speexdsp's adaptive jitter buffer (speex/speex_jitter.h), the baseline: it grows
//    and shrinks its delay whenever its histogram says so, also in the middle of a word. On
//    (re)synchronisation (the first packet, or the buffer's own reset after > 20 missing frames)
//    playout waits the last measured delay (at least `initial_delay_ms`).
// Measured against each other on the same arrivals: tests/audio/voice_test.cpp (a TCP path with
// loss, simulated) and tests/voice/voice_session_test.cpp (a real impaired path, both listening).
//
// Not thread-safe: put() and next() from one thread (or under one lock). No allocation after
// construction. Movable, not copyable.
#include <cstdint>
#include <memory>
#include <span>
#include <string_view>

#include "volcast/audio/voice_format.hpp"

namespace volcast::audio {
namespace detail {
class Buffer;
}

/// One 20 ms frame of output and where it came from.
struct PlayedFrame {
  enum class Source : uint8_t {
    kPacket,     ///< decoded from its packet
    kFec,        ///< lost; recovered from the next packet's in-band FEC
    kConcealed,  ///< lost (or inserted by the buffer mid-talk to grow its delay); Opus PLC
    kSilence,    ///< not talking: before the first packet, DTX, or fate not known yet (see above)
  };
  Source source = Source::kSilence;
  uint32_t frame = 0;      ///< the sender's frame number this output stands for (estimated if none)
  int64_t capture_us = 0;  ///< sender's capture time of its first sample, server clock, µs
                           ///< (extrapolated from the last packet at 20 ms/frame if not a packet)
};

/// Counters since construction. Packets: put() calls; frames: next() calls.
struct VoiceStreamStats {
  uint64_t packets = 0;        ///< well-formed packets put (including duplicates and late ones)
  uint64_t duplicates = 0;     ///< packets whose sequence was already received
  uint64_t late = 0;           ///< packets too late to play (arrived after their time, or discarded
                               ///< by the buffer unplayed when it shrank its delay)
  uint64_t malformed = 0;      ///< put() packets that are not is_voice_packet(): dropped
  uint64_t lost = 0;           ///< sequence numbers never played (lost in transit, or late)
  uint64_t frames_played = 0;  ///< next() calls
  uint64_t frames_from_packets = 0;  ///< Source::kPacket
  uint64_t frames_fec = 0;           ///< Source::kFec
  uint64_t frames_concealed = 0;     ///< Source::kConcealed (corrected as the header describes)
  uint64_t frames_silent = 0;        ///< Source::kSilence (corrected as the header describes)
  uint64_t frames_inserted = 0;      ///< of frames_silent: quiet frames inserted to grow the delay
  uint64_t frames_skipped = 0;       ///< quiet packets decoded, not played, to shrink it (kSpurt)
  uint64_t frames_held = 0;          ///< hold() calls: blocks the listener's loop missed
  int delay_ms = 0;  ///< the jitter buffer's current delay: how long the newest packet waits, ms
  /// (fec + concealed) / (packets + fec + concealed frames, i.e. the frames while talking), in
  /// percent; 0 before any talking.
  double concealed_percent() const {
    const uint64_t talking = frames_from_packets + frames_fec + frames_concealed;
    return talking == 0 ? 0.0
                        : 100.0 * static_cast<double>(frames_fec + frames_concealed) /
                              static_cast<double>(talking);
  }
};

/// Which playout buffer a VoiceStream uses (see the file comment).
enum class PlayoutKind : uint8_t {
  kSpurt,     ///< Volcast's: delay changes only between talk spurts or across quiet frames
  kSpeexdsp,  ///< speexdsp's adaptive jitter buffer
};

/// Parses "spurt" or "speexdsp"; throws volcast::Error naming the text otherwise.
PlayoutKind parse_playout_kind(std::string_view text);
const char* to_string(PlayoutKind kind);

struct VoiceStreamConfig {
  PlayoutKind playout = PlayoutKind::kSpurt;
  int initial_delay_ms = 0;  ///< the least a talk spurt's first frame waits, ms (0..1000)
  /// The share of packets the delay may let arrive too late (0..50 %). kSpurt resumes a stalled
  /// stream rather than lose what was late, so it can afford more than speexdsp (tuned to 1 %
  /// for TCP before kSpurt).
  int max_late_percent = 2;
};

/// One speaker's jitter buffer and decoder (see the file comment).
class VoiceStream {
 public:
  /// Throws volcast::Error for a config field out of its range.
  explicit VoiceStream(const VoiceStreamConfig& config = {});
  ~VoiceStream();
  VoiceStream(VoiceStream&&) noexcept;
  VoiceStream& operator=(VoiceStream&&) noexcept;

  /// Queues a packet (copied). `capture_us`: the sender's capture time of the frame's first
  /// sample, server clock. Duplicates and packets too late to play are ignored (counted); a
  /// malformed packet (not is_voice_packet) is dropped and counted, never thrown.
  void put(uint32_t sequence, uint32_t frame, int64_t capture_us, std::span<const uint8_t> packet);
  /// Plays the next 20 ms into `out` (float [-1, 1]); call once per 20 ms of the playout clock.
  PlayedFrame next(std::span<float, kFrameSamples> out);
  /// In place of next() for a block the listener could not play (its loop ran a whole block
  /// late: a loaded machine; the loudspeaker, a file, got silence). kSpurt: the playout clock
  /// advances, the play position does not -- what was due plays at the next next(), a block later,
  /// as a stalled stream resumes (its packets, held up by the same stall, are then on time), and
  /// the delay gained is given back where no one hears it. kSpeexdsp: played into nothing (speexdsp
  /// has no pause), as next() would.
  void hold();
  VoiceStreamStats stats() const;

 private:
  std::unique_ptr<detail::Buffer> buffer_;
};

}  // namespace volcast::audio
