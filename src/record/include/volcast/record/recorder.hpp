#pragma once
// A server-side recorder: one more consumer of a tier (Server::add_tier_tap) and of the session's
// voices and drawing, writing on its own thread so that the disk never holds up the tier's live
// viewers.
#include <array>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <mutex>
#include <string>
#include <thread>

#include "volcast/net/stream/server.hpp"
#include "volcast/record/recording.hpp"

namespace volcast {

/// What a BackgroundRecorder has done so far.
struct RecorderStats {
  uint64_t frame_sets = 0;  ///< written
  uint64_t bytes = 0;       ///< file size
  /// Frame sets not recorded because the queue was full (the disk slower than the stream), and
  /// the deltas after them up to the next key frame set (they could not be decoded).
  uint64_t dropped = 0;
  uint64_t voice_packets = 0;  ///< voice packets written
  /// Voice packets not recorded: the voice queue was full, or the packet was empty or over
  /// kMaxRecordedVoiceBytes.
  uint64_t voice_dropped = 0;
  uint64_t drawings = 0;  ///< drawing messages written (0x51, 0x52)
  /// Drawing messages not recorded: the drawing queue was full, or the message was refused
  /// (RecordingWriter::append_drawing: another type, oversized, malformed).
  uint64_t drawing_dropped = 0;
  std::string error;  ///< what stopped the recording (disk full, ...), else empty
};

/// Writes a tier's frame sets and the session's voices and drawing to a recording (recording.hpp)
/// on a thread of its own.
class BackgroundRecorder {
 public:
  /// Creates the file (RecordingWriter: throws Error if it exists or cannot be made). At most
  /// `max_queued` frame sets, `max_queued_voices` voice packets (preallocated, ~2.6 KB each) and
  /// `max_queued_drawings` drawing messages (up to kMaxRecordedDrawingBytes each) wait for the
  /// disk.
  BackgroundRecorder(const std::filesystem::path& path, const RecordingStream& stream,
                     RecordingWriterOptions options = {}, size_t max_queued = 64,
                     size_t max_queued_voices = 256, size_t max_queued_drawings = 256);
  /// stop().
  ~BackgroundRecorder();
  BackgroundRecorder(const BackgroundRecorder&) = delete;
  BackgroundRecorder& operator=(const BackgroundRecorder&) = delete;

  /// Queues `f` (holding its buffer) and returns at once: a Server tap. A full queue drops it and
  /// the deltas after it up to the next key frame set. After an error nothing more is queued.
  /// Thread-safe.
  void push(const TierFrameSet& f);
  /// Queues a Speaker record (RecordingWriter::append_speaker): call it when a participant joins
  /// or changes its name, before pushing its voice. Never dropped. Thread-safe.
  void push_speaker(uint32_t participant, const std::string& name, uint8_t role);
  /// Copies one voice packet (RecordingWriter::append_voice) into the queue and returns at once;
  /// no allocation. A full queue, an empty packet or one over kMaxRecordedVoiceBytes is dropped
  /// and counted (RecorderStats::voice_dropped). Thread-safe.
  void push_voice(uint32_t participant, uint32_t sequence, uint32_t frame, int64_t capture_us,
                  std::span<const uint8_t> opus);
  /// Copies one drawing message (RecordingWriter::append_drawing: session message `type` 0x51 or
  /// 0x52, its payload as the session carried it, received at `received_us` on the server's
  /// clock) into the queue and returns at once, never waiting for the disk (it parses the
  /// payload, as the writer would: a few microseconds). A full queue or a message the writer would
  /// refuse (another type, over kMaxRecordedDrawingBytes, malformed) is dropped and counted
  /// (RecorderStats::drawing_dropped). Push the Speaker of its author first. Thread-safe.
  void push_drawing(uint8_t type, int64_t received_us, std::span<const uint8_t> payload);
  /// Writes what is queued, closes the file (writes its index) and joins the thread. Idempotent.
  void stop();
  RecorderStats stats() const;
  const std::filesystem::path& path() const { return writer_.path(); }

 private:
  struct QueuedVoice {
    uint32_t participant = 0, sequence = 0, frame = 0;
    int64_t capture_us = 0;
    size_t bytes = 0;
    std::array<uint8_t, kMaxRecordedVoiceBytes> opus{};
  };
  struct QueuedDrawing {
    uint8_t type = 0;
    int64_t received_us = 0;
    std::vector<uint8_t> payload;
  };
  void run();
  bool idle() const {
    return queue_.empty() && speakers_.empty() && voice_count_ == 0 && drawings_.empty();
  }
  RecordingWriter writer_;
  size_t max_queued_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<TierFrameSet> queue_;           // guarded by mutex_
  std::deque<RecordedSpeaker> speakers_;     // guarded by mutex_
  std::vector<QueuedVoice> voices_;          // guarded by mutex_: a ring of max_queued_voices
  size_t voice_head_ = 0, voice_count_ = 0;  // guarded by mutex_
  std::vector<QueuedVoice> writing_;    // the recorder thread's own: voices taken from the ring
  std::deque<QueuedDrawing> drawings_;  // guarded by mutex_: at most max_queued_drawings_
  size_t max_queued_drawings_;
  RecorderStats stats_;           // guarded by mutex_
  bool waiting_for_key_ = false;  // guarded by mutex_: dropped one, deltas cannot follow
  bool stopping_ = false;         // guarded by mutex_
  std::thread thread_;
};

}  // namespace volcast
