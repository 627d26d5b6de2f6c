#pragma once
// A server-side recorder: one more consumer of a tier (Server::add_tier_tap), writing on its own
// thread so that the disk never holds up the tier's live viewers.
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
  std::string error;  ///< what stopped the recording (disk full, ...), else empty
};

/// Writes a tier's frame sets to a recording (recording.hpp) on a thread of its own.
class BackgroundRecorder {
 public:
  /// Creates the file (RecordingWriter: throws Error if it exists or cannot be made). At most
  /// `max_queued` frame sets wait for the disk.
  BackgroundRecorder(const std::filesystem::path& path, const RecordingStream& stream,
                     RecordingWriterOptions options = {}, size_t max_queued = 64);
  /// stop().
  ~BackgroundRecorder();
  BackgroundRecorder(const BackgroundRecorder&) = delete;
  BackgroundRecorder& operator=(const BackgroundRecorder&) = delete;

  /// Queues `f` (holding its buffer) and returns at once: a Server tap. A full queue drops it and
  /// the deltas after it up to the next key frame set. After an error nothing more is queued.
  /// Thread-safe.
  void push(const TierFrameSet& f);
  /// Writes what is queued, closes the file (writes its index) and joins the thread. Idempotent.
  void stop();
  RecorderStats stats() const;
  const std::filesystem::path& path() const { return writer_.path(); }

 private:
  void run();
  RecordingWriter writer_;
  size_t max_queued_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<TierFrameSet> queue_;  // guarded by mutex_
  RecorderStats stats_;             // guarded by mutex_
  bool waiting_for_key_ = false;    // guarded by mutex_: dropped one, deltas cannot follow
  bool stopping_ = false;           // guarded by mutex_
  std::thread thread_;
};

}  // namespace volcast
