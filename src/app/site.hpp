#pragma once
// A site: several sources (one camera each) read in lockstep at a fixed rate, filtered per camera,
// and published as frame sets to a Server.
#include <atomic>
#include <memory>
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
  /// frame (a 5 fps recording in a 30 fps site appears in 6 frame sets). `filters` holds one
  /// configuration per source (or none: no filtering); a camera whose configuration enables
  /// nothing is passed through. Throws Error if a filter chain cannot be built.
  SitePlayer(std::vector<std::unique_ptr<FrameSource>> sources, double fps,
             const std::vector<FilterConfig>& filters = {});
  ~SitePlayer();

  /// The cameras as the server announces them in Welcome.
  std::vector<protocol::CameraInfo> cameras() const;
  double fps() const { return fps_; }
  /// Starts publishing to `server` on a background thread: one frame set per 1/fps, each stamped
  /// with the wall clock when its frames were read. Ticks that reading overran are skipped, never
  /// queued. A frame that fails to read is logged and its frame set skipped.
  void start(Server& server);
  void stop();
  uint64_t frame_sets_published() const { return published_; }

 private:
  void run(Server& server);
  std::vector<std::unique_ptr<FrameSource>> sources_;
  std::vector<std::optional<FilterChain>> chains_;
  std::vector<CameraFrame> last_frames_;  // each camera's latest frame, repeated until its next
  double fps_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<uint64_t> published_{0};
};

}  // namespace volcast
