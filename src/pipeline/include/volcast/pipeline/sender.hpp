#pragma once
// The sender pipeline: a site's sources (one camera each) read in lockstep at a fixed rate,
// filtered per camera, and published as frame sets to a Server, which encodes them per tier.
#include <atomic>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <unordered_set>
#include <vector>

#include "volcast/capture/source.hpp"
#include "volcast/filter/chain.hpp"
#include "volcast/net/stream/server.hpp"

namespace volcast {

/// How a site treats cameras whose frames cannot be read, and the clock it runs on.
struct SiteOptions {
  /// A camera whose reads fail this many times in a row is marked failed (logged once). At least 1.
  int max_read_failures = 30;
  /// The site's clock: steady time in µs (any epoch) and a wait until such a time. Both unset:
  /// std::chrono::steady_clock and a sleep. A test steps a site tick by tick with its own pair
  /// (each wait returns once the test allows the next tick); SitePlayer::stop() joins the thread,
  /// so such a wait must return once the test is done.
  std::function<int64_t()> now_us;
  std::function<void(int64_t)> sleep_until_us;
};

/// One camera's read health (SitePlayer::camera_status).
struct CameraStatus {
  uint64_t frames_read = 0;      ///< frames read (and filtered) from the source
  uint64_t read_failures = 0;    ///< frames that could not be read and were skipped, in all
  int consecutive_failures = 0;  ///< failed reads since the last good one
  /// consecutive_failures reached SiteOptions::max_read_failures; cleared by the next good read.
  bool failed = false;
  std::string last_error;  ///< the latest failed read's error, or empty
};

class SitePlayer {
 public:
  /// Receives each frame set the site publishes, on the player's thread.
  using Publish = std::function<void(std::shared_ptr<const CapturedFrameSet>)>;

  /// Takes ownership of the sources. `fps` is the site's frame-set rate; 0 = the fastest source's
  /// rate. Each source is paced at its own rate: its frame k is due at k / (its fps) after the
  /// start and is read at the tick nearest that time (or the first tick after it, when ticks were
  /// skipped); between its frames, frame sets repeat its last frame (a 5 fps recording in a 30 fps
  /// site appears in 6 frame sets, shared, not copied). A source slower than the site's ticks
  /// allow is read once per tick and falls behind its own time, never queued.
  /// `filters` holds one configuration per source (or none: no filtering); a camera whose
  /// configuration enables nothing is passed through. Throws Error if a filter chain cannot be
  /// built or an option is out of range.
  ///
  /// A frame that cannot be read (the source throws, or its filter chain does) is skipped: one
  /// warning per distinct error (it names the file and why; not repeated when the recording loops
  /// back to it), and the camera repeats its last good frame -- or, before it has one, sends an
  /// empty frame (depth of its calibrated size, all 0 = invalid; no color). The other cameras are
  /// not held up. After options.max_read_failures failed reads in a row the camera is marked
  /// failed (logged once, camera_status()); it still sends its last good frame, so every frame set
  /// stays complete, and keeps trying at its own rate: its next good read recovers it (logged).
  SitePlayer(std::vector<std::unique_ptr<FrameSource>> sources, double fps,
             const std::vector<FilterConfig>& filters = {}, SiteOptions options = {});
  ~SitePlayer();

  /// The cameras as the server announces them in Welcome.
  std::vector<protocol::CameraInfo> cameras() const;
  double fps() const { return fps_; }
  /// Starts publishing to `server` on a background thread: one frame set per 1/fps, stamped with
  /// the wall clock when its frames were read (capture) and filtered. Ticks that reading overran
  /// are skipped, never queued.
  void start(Server& server);
  /// As start(Server&), handing each frame set to `publish` instead.
  void start(Publish publish);
  void stop();
  uint64_t frame_sets_published() const { return published_; }
  /// Each camera's read health, in camera order. Thread-safe.
  std::vector<CameraStatus> camera_status() const;

 private:
  void run(const Publish& publish);
  // A frame buffer for camera i that no published frame set still holds (reused), or a new one.
  std::shared_ptr<CameraFrame> spare_frame(size_t i);
  void read_succeeded(size_t i);
  void read_failed(size_t i, const std::string& error);
  std::vector<std::unique_ptr<FrameSource>> sources_;
  std::vector<std::optional<FilterChain>> chains_;
  std::vector<std::shared_ptr<const CameraFrame>> last_frames_;     // each camera's latest frame
  std::vector<std::vector<std::shared_ptr<CameraFrame>>> buffers_;  // per camera, recycled
  std::vector<std::unordered_set<std::string>> warned_;  // per camera: errors already logged
  SiteOptions options_;
  double fps_;
  mutable std::mutex status_mutex_;
  std::vector<CameraStatus> status_;  // guarded by status_mutex_
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<uint64_t> published_{0};
};

}  // namespace volcast
