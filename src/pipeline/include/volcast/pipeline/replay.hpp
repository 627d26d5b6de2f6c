#pragma once
// Replaying a recording (volcast/record/recording.hpp) as a site: its frame sets published to a
// Server at the pace they were recorded, decoded for every other tier and passed through as
// recorded to viewers of the recorded tier (no re-encoding).
#include <atomic>
#include <filesystem>
#include <functional>
#include <memory>
#include <thread>
#include <vector>

#include "volcast/core/frame_pool.hpp"
#include "volcast/net/stream/server.hpp"
#include "volcast/record/decode.hpp"
#include "volcast/record/recording.hpp"

namespace volcast {

struct ReplayOptions {
  double from_s = 0;  ///< start this many seconds after the recording's first frame set
  double to_s = -1;   ///< stop this many seconds after it (< 0: at its end)
  bool loop = true;   ///< start again at `from_s` after `to_s`
};

class ReplayPlayer {
 public:
  using Publish = std::function<void(std::shared_ptr<const CapturedFrameSet>)>;

  /// Opens the recording (RecordingReader: throws Error naming what is wrong with the file) and
  /// picks the frame sets played in [from_s, to_s] after its first (timeline()). Throws Error if
  /// that range holds none, or the recording's codecs are not in this build.
  ReplayPlayer(const std::filesystem::path& path, ReplayOptions options = {});
  ~ReplayPlayer();

  /// The cameras as the recording's server announced them (calibration, world_from_camera,
  /// names).
  std::vector<protocol::CameraInfo> cameras() const;
  const RecordingInfo& info() const { return reader_.info(); }
  /// Frame sets per second of the selected range (as recorded).
  double fps() const;
  /// When each frame set plays: its recorded capture time minus the first one's, with absurd gaps
  /// (backwards, or over kMaxReplayGapUs: a lying or edited file) clamped to the frame interval
  /// and logged once when the player opens the file.
  const PlaybackTimeline& timeline() const { return timeline_; }
  /// Starts publishing on a background thread: frame set k at the start time plus its timeline()
  /// offset minus the first selected one's, each stamped with this machine's wall clock and
  /// carrying its recorded body (CapturedFrameSet::encoded). A frame set that cannot be read or
  /// decoded is skipped with one warning naming it and the offset.
  void start(Server& server);
  void start(Publish publish);
  /// Stops the thread (returns once it has). Idempotent.
  void stop();
  uint64_t frame_sets_published() const { return published_; }
  uint64_t frame_sets_skipped() const { return skipped_; }
  /// True once a non-looping replay has published its last frame set.
  bool finished() const { return finished_; }

 private:
  void run(const Publish& publish);
  RecordingReader reader_;
  RecordingDecoder decoder_;
  ReplayOptions options_;
  PlaybackTimeline timeline_;    // when each frame set plays (absurd gaps clamped)
  size_t first_ = 0, last_ = 0;  // the selected frame sets [first_, last_]
  FramePool buffers_;            // per camera, recycled
  std::thread thread_;
  std::atomic<bool> stop_{false}, finished_{false};
  std::atomic<uint64_t> published_{0}, skipped_{0};
};

}  // namespace volcast
