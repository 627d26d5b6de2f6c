#pragma once
// Recordings of the encoded stream (.vcr): one tier's frame sets exactly as the server sent them,
// and the session's voices and drawing as the recorder heard them, in an append-only file that
// survives the recorder being killed or the disk filling up.
//
// File format, version 3 (this build writes 3 and reads 1, 2 and 3; little-endian throughout):
//   File header, 16 bytes: magic "VCRECORD" (8 bytes) | format version u16 (= 3; 2 for files
//     without drawing, 1 for files without voices, written before them) | reserved u16 (= 0) |
//     CRC-32 (zlib's, ISO-HDLC) of the 12 bytes before it.
//   Records, back to back, each a 16-byte record header then its payload:
//     type u8 | reserved 3 bytes (= 0) | payload length u32 | CRC-32 of the payload | CRC-32 of
//     the header's first 12 bytes. The header's own CRC is checked before its length is trusted.
//   Record types:
//     1 Stream, exactly once, first: depth codec string | color codec string | color quality u8 |
//       recorder's wall clock when recording began i64 (us) | origin string (who recorded what, for
//       people) | the Welcome payload as the server sent it (protocol.hpp 0.2, byte string).
//       Strings are u16 length + UTF-8, a byte string u32 length + bytes (core/wire.hpp).
//     2 FrameSet: the FrameSet body (protocol.hpp 1.1: everything after the send time: sequence,
//       flags, capture/filter/encode times, per camera device time, depth and color streams),
//       byte-identical to what the tier's viewers were sent. Written with one write() each.
//     3 Index, written when the recording is closed:
//       version 1: frame-set count u32, then per frame set its record's file offset u64 |
//         sequence u64 | capture time i64 (us, the sender's clock) | flags u8 (25 bytes).
//       version 2: the same, then speaker-record count u32, then per Speaker record its file
//         offset u64 | participant u32 | role u8 | display name string; then voice count u32, then
//         per Voice record its file offset u64 | participant u32 | sequence u32 | frame u32 |
//         capture time i64 | Opus length u16 (30 bytes).
//       version 3: the same, then drawing count u32, then per Drawing record its file offset u64 |
//         session message type u8 | receive time i64 | session payload length u32 (21 bytes).
//       Each list in file order; together with the frame sets they tile the file from the end of
//       the Stream record to the Index.
//     4 End, last, directly after the Index: the Index record's file offset u64.
//     5 Speaker (version 2), before the first Voice of its participant, again only if its name or
//       role changed (the last one holds): participant u32 | display name string | role u8 (0 a
//       remote participant, 1 the OR site; others kept as they are).
//     6 Voice (version 2), one Opus packet (RFC 6716) as the session carried it: participant u32 |
//       sequence u32 (+1 per packet sent) | frame u32 (+1 per 20 ms frame captured; DTX skips
//       frames) | capture time i64 (us, the server's clock, as frame sets' capture times) | Opus
//       packet byte string (1..1275 bytes, RFC 6716 3.4). Not synced one by one: the writer's
//       sync interval covers voices and frame sets alike.
//     7 Drawing (version 3), one annotation message as the session carried it to the recorder
//       (volcast/session/annotations.hpp): session message type u8 (0x51 Annotation, 0x52 Erased)
//       | receive time i64 (us, the server's clock, as voices' capture times) | the message's
//       payload byte string (byte-identical to what the session carried; 1..
//       kMaxRecordedDrawingBytes bytes). The annotations that exist when the recorder joins come
//       first (the session sends them on joining), received then. A Speaker record names an
//       author or eraser where the recorder knew them (none for participant 0, the server).
//   A file that does not end in an End record pointing at a valid Index (the recorder was killed,
//   the machine lost power, the disk filled) is indexed by scanning its records: the frame sets,
//   voices and drawing up to the last complete record replay; an incomplete last record (one that
//   runs past the end of the file or whose payload fails its CRC with nothing after it), or zeros
//   where a record should begin, is the tail a stopped recorder leaves and is reported, not
//   refused. Anything else -- a bad file header, a record header that fails its CRC with data after
//   it, a payload that fails its CRC with records after it, an unknown type (5 and 6 in a
//   version-1 file, 7 in a version-1 or 2 file), a Stream that is missing, repeated or malformed, a
//   Speaker or Voice that is malformed (a voice of 0 or over 1275 bytes, a Voice before its
//   participant's Speaker), a Drawing that is malformed (another message type, a length that does
//   not fit, a payload session::parse_annotation or parse_erased refuses), an Index that does not
//   match the records -- is corruption: an Error naming the file and the byte offset. A record's
//   length is checked against its type's limit before anything is allocated for it.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "volcast/codec/tier.hpp"
#include "volcast/net/protocol/protocol.hpp"

namespace volcast {

inline constexpr uint16_t kRecordingVersion = 3;  ///< written; 1, 2 and 3 are read
inline constexpr size_t kRecordingFileHeaderBytes = 16;
inline constexpr size_t kRecordHeaderBytes = 16;
/// The largest record payload a reader accepts (bytes): a frame set within the protocol's limit.
inline constexpr uint32_t kMaxRecordBytes = protocol::kMaxPayloadBytes;

enum class RecordType : uint8_t {
  kStream = 1,
  kFrameSet = 2,
  kIndex = 3,
  kEnd = 4,
  kSpeaker = 5,
  kVoice = 6,
  kDrawing = 7
};

/// The largest Opus packet a Voice record holds (bytes): one frame, RFC 6716 section 3.4.
inline constexpr size_t kMaxRecordedVoiceBytes = 1275;
/// One voice frame (us): 20 ms Opus frames at 48 kHz, as the session carries them.
inline constexpr int64_t kVoiceFrameUs = 20'000;

/// The largest session payload a Drawing record holds (bytes): above the largest 0x51 Annotation
/// (annotations.hpp: a stroke of kMaxStrokePoints points, or a label of kMaxLabelBytes bytes).
inline constexpr size_t kMaxRecordedDrawingBytes = 4096;
/// The session message types a Drawing record holds (annotations.hpp).
inline constexpr uint8_t kDrawingAnnotation = 0x51, kDrawingErased = 0x52;

/// Who spoke or drew (a Speaker record).
struct RecordedSpeaker {
  uint32_t participant = 0;  ///< the session's participant id
  std::string name;          ///< display name
  uint8_t role = 0;          ///< 0 a remote participant, 1 the OR site
};

/// One voice packet's place in the file (a Voice record).
struct RecordedVoice {
  uint64_t offset = 0;  ///< file offset of its record header
  uint32_t participant = 0;
  uint32_t sequence = 0;   ///< +1 per packet the speaker sent
  uint32_t frame = 0;      ///< +1 per 20 ms frame the speaker captured (DTX skips frames)
  int64_t capture_us = 0;  ///< the server's clock (us), as frame sets' capture times
  uint16_t bytes = 0;      ///< the Opus packet's length, 1..kMaxRecordedVoiceBytes
};

/// One annotation message's place in the file (a Drawing record).
struct RecordedDrawing {
  uint64_t offset = 0;      ///< file offset of its record header
  uint8_t type = 0;         ///< kDrawingAnnotation (0x51) or kDrawingErased (0x52)
  int64_t received_us = 0;  ///< when the recorder received it, the server's clock (us)
  uint32_t bytes = 0;       ///< the session payload's length, 1..kMaxRecordedDrawingBytes
};

/// One voice packet with its Opus bytes (RFC 6716), as a decoder takes it.
struct RecordedVoicePacket {
  uint32_t participant = 0;
  uint32_t sequence = 0;
  uint32_t frame = 0;
  int64_t capture_us = 0;      ///< the server's clock (us)
  std::vector<uint8_t> bytes;  ///< one Opus packet, 1..kMaxRecordedVoiceBytes bytes
};

/// What a recording is of (its Stream record).
struct RecordingStream {
  Tier tier;                  ///< of every frame set (frame_divisor 1)
  int64_t started_us = 0;     ///< recorder's wall clock when it began (us)
  std::string origin;         ///< e.g. "volcast record 10.0.0.2:7300"
  protocol::Welcome welcome;  ///< the cameras as the server announced them
};

/// One frame set's place in the file.
struct RecordedFrameSet {
  uint64_t offset = 0;  ///< file offset of its record header
  uint32_t bytes = 0;   ///< its body's length
  uint64_t sequence = 0;
  int64_t capture_us = 0;  ///< sender's wall clock (us)
  bool key = false;        ///< every camera decodes on its own (protocol.hpp flags bit 0)
};

struct RecordingWriterOptions {
  /// fdatasync at most this often (ms) while appending, so a power cut loses at most this much;
  /// 0: after every frame set. close() always syncs.
  int sync_interval_ms = 1000;
  bool overwrite = false;  ///< replace an existing file (else an existing path is an Error)
};

/// Appends frame sets to a new recording. Not thread-safe: one caller at a time.
class RecordingWriter {
 public:
  /// Creates `path` with mode 0600 (it shows the OR: its owner's only, whatever the umask; a file
  /// it replaces gets 0600 too) and writes the file header and the Stream record. Throws Error if
  /// the file exists (without options.overwrite), cannot be created, or the disk is full.
  RecordingWriter(const std::filesystem::path& path, const RecordingStream& stream,
                  RecordingWriterOptions options = {});
  /// Closes (index and End written) if close() was not called; never throws.
  ~RecordingWriter();
  RecordingWriter(const RecordingWriter&) = delete;
  RecordingWriter& operator=(const RecordingWriter&) = delete;

  /// Appends one FrameSet body (protocol.hpp 1.1, as serialize_frame_set_body writes it) as one
  /// record, with a single write(). Throws Error if the body's head is malformed, or the write
  /// fails; a write that fails for want of space (ENOSPC, EDQUOT, EFBIG) says the disk is full,
  /// and the file is cut back to its last complete frame set and synced, so everything before it
  /// stays and replays. After a throw the writer accepts no more frame sets.
  void append(std::span<const uint8_t> body);
  /// Appends a Speaker record for `participant` (display `name`, `role` 0 remote / 1 OR site)
  /// unless the last one written for it says the same. Throws Error for a name over 65535 bytes
  /// or as append() does when the write fails.
  void append_speaker(uint32_t participant, const std::string& name, uint8_t role);
  /// Appends one Voice record (the Opus packet `opus`, 1..kMaxRecordedVoiceBytes bytes; times as
  /// at RecordedVoice) with a single write, synced with the frame sets (options.sync_interval_ms).
  /// A participant with no Speaker yet gets one first, named "participant <id>", role 0. Throws
  /// Error for an empty or oversized packet (nothing written, the writer goes on) or as append()
  /// does when the write fails. No allocation once its buffers have grown (the index aside).
  void append_voice(uint32_t participant, uint32_t sequence, uint32_t frame, int64_t capture_us,
                    std::span<const uint8_t> opus);
  void append_voice(const RecordedVoicePacket& p) {
    append_voice(p.participant, p.sequence, p.frame, p.capture_us, p.bytes);
  }
  /// Appends one Drawing record: the session message `type` (kDrawingAnnotation or
  /// kDrawingErased) with its `payload` exactly as the session carried it, received at
  /// `received_us` (the server's clock), with a single write, synced with the frame sets. Throws
  /// Error for another type, a payload over kMaxRecordedDrawingBytes or one that
  /// session::parse_annotation / parse_erased refuses (nothing written, the writer goes on), or as
  /// append() does when the write fails.
  void append_drawing(uint8_t type, int64_t received_us, std::span<const uint8_t> payload);
  /// Writes the Index and End records and syncs. Idempotent. Throws Error if that fails (the frame
  /// sets stay: a reader indexes them by scanning).
  void close();

  const std::filesystem::path& path() const { return path_; }
  uint64_t frame_sets() const { return index_.size(); }
  uint64_t voices() const { return voices_.size(); }
  uint64_t drawings() const { return drawings_.size(); }
  uint64_t bytes() const { return end_; }  ///< file size so far

 private:
  void write_record(RecordType type, std::span<const uint8_t> head, std::span<const uint8_t> body);
  [[noreturn]] void fail_write(int error_number, const char* what);
  void check_open() const;
  void maybe_sync(const char* what);
  std::filesystem::path path_;
  RecordingWriterOptions options_;
  int fd_ = -1;
  uint64_t end_ = 0;  // bytes written and complete
  int64_t last_sync_us_ = 0;
  bool failed_ = false, closed_ = false;
  std::vector<RecordedFrameSet> index_;
  struct SpeakerEntry {
    uint64_t offset;
    RecordedSpeaker speaker;
  };
  std::vector<SpeakerEntry> speakers_;  // every Speaker record, in file order
  std::vector<RecordedVoice> voices_;
  std::vector<RecordedDrawing> drawings_;
  std::vector<uint8_t> scratch_;  // a Voice or Speaker record's payload
};

/// What a reader found in a recording.
struct RecordingInfo {
  RecordingStream stream;
  std::vector<RecordedFrameSet> frame_sets;  ///< in file order
  uint16_t version =
      kRecordingVersion;  ///< the file's format version (1: no voices, 2: no drawing)
  /// One per participant, in the order they first spoke; name and role from their last Speaker.
  std::vector<RecordedSpeaker> speakers;
  std::vector<RecordedVoice> voices;      ///< every Voice record, in file order
  std::vector<RecordedDrawing> drawings;  ///< every Drawing record, in file order
  uint64_t file_bytes = 0;
  bool closed = false;  ///< ends in a valid Index and End (the recorder closed it)
  /// Where an incomplete tail begins (a stopped recorder's last, partial write), if there is one;
  /// frame sets before it replay.
  std::optional<uint64_t> incomplete_tail_at;
  std::string tail_reason;  ///< what was incomplete there
  /// Capture time of the last frame set minus the first's (us; 0 for fewer than two).
  int64_t duration_us() const {
    return frame_sets.size() < 2 ? 0 : frame_sets.back().capture_us - frame_sets.front().capture_us;
  }
};

/// A gap between consecutive capture times longer than this (us) is not replayed as recorded:
/// a camera that paused for a few seconds is still shown as it was, but a clock that jumped (a
/// file edited, a sender's clock set mid-recording) would stall the replay for days.
inline constexpr int64_t kMaxReplayGapUs = 5'000'000;

/// When each frame set of a recording is played, relative to the first (us). Capture times are the
/// sender's wall clock and a file may lie: a gap that runs backwards or is longer than
/// kMaxReplayGapUs is replaced by the recording's frame interval (the median of its other gaps,
/// 33,333 us if it has none) and counted.
struct PlaybackTimeline {
  std::vector<int64_t> offset_us;  ///< per frame set; offset_us[0] = 0, non-decreasing
  int64_t frame_interval_us = 33'333;
  size_t clamped_gaps = 0;           ///< gaps replaced
  size_t first_clamped = 0;          ///< frame set k whose gap from k - 1 was the first replaced
  int64_t first_clamped_gap_us = 0;  ///< that gap as recorded (negative: backwards)
  /// The time of the last frame set (us; 0 for fewer than two).
  int64_t duration_us() const { return offset_us.size() < 2 ? 0 : offset_us.back(); }
};

/// The playback timeline of `sets` (in file order), as described at PlaybackTimeline.
PlaybackTimeline playback_timeline(std::span<const RecordedFrameSet> sets);

/// When a recording's voice packets play in a replay of its frame sets [first, last] (a
/// ReplayPlayer's pass; volcast/pipeline/replay.hpp), in sync with them: a packet captured D us
/// after frame set k (the last frame set captured at or before it) plays D us after k does, i.e.
/// at timeline.offset_us[k] + D. A pass lasts from its first frame set to one frame interval
/// after its last; it holds the packets whose frame set k is in [first, last] and whose D is less
/// than the replayed gap to frame set k + 1 (for k = last: the frame interval).
struct VoiceCue {
  size_t voice = 0;      ///< its index in RecordingInfo::voices
  size_t speaker = 0;    ///< its index in VoicePlan::speakers
  size_t frame_set = 0;  ///< k
  /// When it plays, from the pass's start: offset_us[k] - offset_us[first] + D.
  int64_t at_us = 0;
};

/// A replay's voices (voice_plan()). Looping, pass p (0, 1, ...) sends each packet with its
/// sequence + p x sequences_per_pass and its frame + p x frames_per_pass of its speaker (mod 2^32):
/// its numbers go on across the wrap (no jump back a jitter buffer would take for a late or a
/// restarted stream), the frame clock advancing with the time a pass takes, the sequence with the
/// packets it holds (so a packet lost in the recording is still a gap, and the wrap none).
struct VoicePlan {
  struct Speaker {
    RecordedSpeaker speaker;  ///< as RecordingInfo::speakers has it (its last Speaker record)
    size_t packets = 0;       ///< its cues
    uint32_t sequences_per_pass = 0;  ///< its highest sequence - its lowest + 1 (in the pass)
    /// max(its highest frame - its lowest + 1, pass_us in 20 ms frames, rounded up)
    uint32_t frames_per_pass = 0;
  };
  std::vector<Speaker> speakers;  ///< those with cues, in RecordingInfo::speakers' order
  std::vector<VoiceCue> cues;     ///< in playing order: at_us (ties: by speaker, capture order)
  int64_t pass_us = 0;            ///< offset_us[last] - offset_us[first] + frame interval
  /// Voices of the recording that have no place on its timeline at all: captured before its first
  /// frame set, a frame interval or more after its last, or in a gap the timeline replays shorter
  /// (PlaybackTimeline: a clock that jumped). Never played.
  size_t outside = 0;
};

/// The voice plan of `info`'s frame sets [first, last] (first <= last < frame_sets.size()) on
/// `timeline` (playback_timeline(info.frame_sets)), as described at VoiceCue and VoicePlan.
VoicePlan voice_plan(const RecordingInfo& info, const PlaybackTimeline& timeline, size_t first,
                     size_t last);

/// When one Drawing record plays in a replay pass of frame sets [first, last] (drawing_plan()).
struct DrawingCue {
  size_t drawing = 0;  ///< its index in RecordingInfo::drawings
  /// When it plays, from the pass's start (us): as a voice would (VoiceCue), received D us after
  /// frame set k at offset_us[k] - offset_us[first] + D; at 0 if it was received before frame set
  /// `first` (what was drawn before the pass is there when it begins); at the next frame set's time
  /// if D is longer than the replayed gap to it (a clamped gap).
  int64_t at_us = 0;
};

/// The drawing of `info` replayed in a pass of its frame sets [first, last] on `timeline`, in
/// playing order (at_us, then file order: an annotation before its erasure). Drawing received one
/// frame interval or more after frame set `last` (or after the recording's last frame set) is not
/// in it.
std::vector<DrawingCue> drawing_plan(const RecordingInfo& info, const PlaybackTimeline& timeline,
                                     size_t first, size_t last);

/// "11.6 days", "3.2 s", "-40 ms": a time span (us) for people.
std::string describe_span_us(int64_t us);

/// Reads a recording. read(), read_voice(), read_drawing() and voices_of() may run on several
/// threads at once (each reads the file with pread and the index, and changes nothing); anything
/// else one caller at a time.
class RecordingReader {
 public:
  /// Opens `path`, reads its Stream record and its index (the Index record of a closed file, else
  /// by scanning every record). Throws Error naming the file and the offset of what is corrupt
  /// (see the format above), or that it is not a Volcast recording.
  explicit RecordingReader(const std::filesystem::path& path);
  ~RecordingReader();
  RecordingReader(const RecordingReader&) = delete;
  RecordingReader& operator=(const RecordingReader&) = delete;

  const RecordingInfo& info() const { return info_; }
  /// Reads frame set `k` (0-based, < info().frame_sets.size()) into `body` from byte `at` on
  /// (resized to at + its length, capacity reused; the first `at` bytes are left as they are:
  /// room for a message's header or send time), checking its record's CRCs. Throws Error naming
  /// the file and offset if they fail or the file changed under it.
  void read(size_t k, std::vector<uint8_t>& body, size_t at = 0);
  /// Reads every frame set, then every voice, then every drawing, and checks their CRCs (and that
  /// each drawing parses); `progress(done, total)` after each (total: frame sets + voices +
  /// drawings). Throws like read() at the first bad one.
  void verify(const std::function<void(size_t, size_t)>& progress = {});

  /// `participant`'s voice packets in capture order (capture time, then frame; file order for
  /// ties); empty for one who never spoke.
  std::vector<RecordedVoice> voices_of(uint32_t participant) const;
  /// Reads the Opus bytes of `v` (an entry of info().voices) into `bytes` (resized, capacity
  /// reused), checking its record's CRCs and that it matches `v`. Throws Error naming the file
  /// and offset otherwise.
  void read_voice(const RecordedVoice& v, std::vector<uint8_t>& bytes);
  /// Every packet of `participant`, bytes included, in capture order (voices_of + read_voice):
  /// what a decoder or a WAV export takes. Throws like read_voice.
  std::vector<RecordedVoicePacket> voices(uint32_t participant);
  /// Reads the session payload of `d` (an entry of info().drawings) into `payload` (resized),
  /// checking its record's CRCs, that it matches `d` and that it parses (parse_annotation or
  /// parse_erased). Throws Error naming the file and offset otherwise.
  void read_drawing(const RecordedDrawing& d, std::vector<uint8_t>& payload);

 private:
  void scan();
  bool read_index();
  void parse_index(std::span<const uint8_t> payload, uint64_t index_at);
  void add_speaker(const RecordedSpeaker& s);
  void add_voice(const RecordedVoice& v, uint64_t at);
  void add_drawing(const RecordedDrawing& d, uint64_t at);
  uint64_t records_at_ = 0;  // where the records after the Stream begin
  std::filesystem::path path_;
  int fd_ = -1;
  RecordingInfo info_;
};

/// The sequence, key flag and capture time at the head of a FrameSet body. Throws Error
/// ("malformed frame set: ...") if the body is shorter than its head.
RecordedFrameSet frame_set_head(std::span<const uint8_t> body);

/// A speaker's voice in a recording, for people (`volcast recording info`).
struct SpeakerSummary {
  RecordedSpeaker speaker;
  size_t packets = 0;
  int64_t sent_us = 0;     ///< packets x 20 ms: the voice actually sent (DTX sends little else)
  int64_t spanned_us = 0;  ///< (last frame - first frame + 1) x 20 ms
  /// First and last capture time relative to the recording's start: the first frame set's capture
  /// time (the clock voices share), or the first voice's in a recording without frame sets (us).
  int64_t first_us = 0, last_us = 0;
};

/// One summary per speaker of `info`, in info.speakers' order.
std::vector<SpeakerSummary> speaker_summaries(const RecordingInfo& info);

/// CRC-32 (ISO-HDLC, as zlib and PNG compute it) of `bytes`.
uint32_t crc32_of(std::span<const uint8_t> bytes);

}  // namespace volcast
