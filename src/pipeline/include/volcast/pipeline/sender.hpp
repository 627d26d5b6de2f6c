#pragma once
// The sender pipeline: a site's sources (one camera each) read in lockstep at a fixed rate,
// filtered per camera, and published as frame sets to a Server, which encodes them per tier.
#include <atomic>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "volcast/capture/source.hpp"
#include "volcast/filter/chain.hpp"
#include "volcast/net/server.hpp"

namespace volcast {

class SitePlayer {
 public:
  /// Takes ownership of the sources. `fps` is the site's frame-set rate; 0 = the fastest source's
  /// rate. Each source is paced at its own rate: between its frames, frame sets repeat its last
  /// frame (a 5 fps recording in a 30 fps site appears in 6 frame sets, shared, not copied).
  /// `filters` holds one configuration per source (or none: no filtering); a camera whose
  /// configuration enables nothing is passed through. Throws Error if a filter chain cannot be
  /// built.
  SitePlayer(std::vector<std::unique_ptr<FrameSource>> sources, double fps,
             const std::vector<FilterConfig>& filters = {});
  ~SitePlayer();

  /// The cameras as the server announces them in Welcome.
  std::vector<protocol::CameraInfo> cameras() const;
  double fps() const { return fps_; }
  /// Starts publishing to `server` on a background thread: one frame set per 1/fps, stamped with
  /// the wall clock when its frames were read (capture) and filtered. Ticks that reading overran
  /// are skipped, never queued. A frame that fails to read is logged and its frame set skipped.
  void start(Server& server);
  void stop();
  uint64_t frame_sets_published() const { return published_; }

 private:
  void run(Server& server);
  // A frame buffer for camera i that no published frame set still holds (reused), or a new one.
  std::shared_ptr<CameraFrame> spare_frame(size_t i);
  std::vector<std::unique_ptr<FrameSource>> sources_;
  std::vector<std::optional<FilterChain>> chains_;
  std::vector<std::shared_ptr<const CameraFrame>> last_frames_;     // each camera's latest frame
  std::vector<std::vector<std::shared_ptr<CameraFrame>>> buffers_;  // per camera, recycled
  double fps_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<uint64_t> published_{0};
};

}  // namespace volcast
