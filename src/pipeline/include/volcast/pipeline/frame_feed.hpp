#pragma once
// The render thread's side of a viewer (run_viewer, receiver.hpp): a Presenter takes the newest
// decoded frames from a FrameFeed and draws them (a window, a headset, a headless target), and
// shows the live figures. What a presenter needs, without the connection (net), the session or
// the figures of the whole run (viewer_result.hpp).
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "volcast/codec/tier.hpp"
#include "volcast/core/calibration.hpp"
#include "volcast/core/frame.hpp"
#include "volcast/net/stream/client.hpp"
#include "volcast/pipeline/stage_stats.hpp"
#include "volcast/render/view.hpp"

namespace volcast {

struct ViewerResult;  // viewer_result.hpp
class FrameFeed;

/// What the render thread does with a session: takes frames from the feed and draws them (into a
/// window, a headset's swapchain or a headless target), setting result.renderer and counting
/// result.frames_rendered. Runs on a thread of its own until feed.finished() (or it calls
/// feed.close()); an exception it throws ends the session (ViewerEnd::kError, "renderer: ...").
using Presenter = std::function<void(FrameFeed& feed, ViewerResult& result)>;

/// Figures for one camera, over the whole run.
struct CameraStats {
  std::string description;  ///< the server's, made printable (volcast/core/text.hpp)
  int width = 0, height = 0;
  uint64_t frames_received = 0;
  uint64_t frames_dropped = 0;  ///< frame sets the server skipped for this viewer
  double mean_depth_bytes = 0, mean_color_bytes = 0;
  double depth_compression_ratio = 0;  ///< raw depth (width*height*2) / mean encoded depth
  double received_fps = 0;
  double mbit_per_s = 0;                          ///< depth + color at the received rate
  double latency_ms_p50 = 0, latency_ms_p99 = 0;  ///< capture timestamp -> ready (stage_stats.hpp)
};

/// A change of the viewer's tier, or a notice that the path cannot carry it (the server's
/// TierChange, protocol.hpp 0.6), as the viewer took it.
struct TierEvent {
  int64_t time_us = 0;  ///< this viewer's wall clock
  Tier tier;            ///< after it
  bool lossless_depth = true;
  bool notice = false;     ///< the same tier: the floor or pin keeps it
  double path_mbit_s = 0;  ///< the server's estimate of the path then
  std::string reason;
};

/// Figures while the session runs, for a viewer's panel: refreshed about twice a second by the
/// receiving thread. Per camera, frames_received and frames_dropped count from the start; fps,
/// Mbit/s and latency cover the last refresh interval. Stages cover the session so far.
struct LiveStats {
  std::vector<CameraStats> cameras;
  std::vector<StageLatency> stages;    ///< kStageNames order; empty until a frame set arrived
                                       ///< (presented and photon: 0 until a picture was shown)
  Tier tier;                           ///< the tier now
  bool adaptive = false;               ///< the server moves it along its ladder
  bool lossless_depth = true;          ///< the tier's depth is lossless
  double path_mbit_s = 0;              ///< the server's last path estimate (0: none said)
  std::vector<TierEvent> tier_events;  ///< the last 8 changes and notices, oldest first
  uint64_t frame_sets_received = 0;
  /// Capture time of the newest frame set handed to the renderer (this viewer's wall clock, us;
  /// 0: none yet): what is drawn is now - this old.
  int64_t newest_capture_us = 0;
  /// Empty while connected; while a cut lasts, "reconnecting" and why (ViewerOptions::reconnect).
  std::string connection;
  uint64_t reconnects = 0;  ///< connections made again after a cut
};

/// The render thread's side of a running session (see Presenter). Thread-safe.
class FrameFeed {
 public:
  struct State;  // frame_feed_state.hpp
  explicit FrameFeed(State& state) : state_(state) {}

  /// The cameras of the session, as the server described them (index = camera).
  const std::vector<CameraCalibration>& cameras() const;
  /// Waits up to `wait` for frames newer than the last ones taken. On new frames: true, with
  /// `frames` (one per camera, null until a camera's first frame arrives; shared and immutable --
  /// the same pointer is the same images) replaced. False on timeout or once finished().
  bool next(std::vector<std::shared_ptr<const CameraFrame>>& frames,
            std::chrono::microseconds wait);
  /// True once the session is over (a limit, the server, an error, close()) and every frame was
  /// taken; the presenter should return.
  bool finished() const;
  /// Ends the session (ViewerEnd::kClosed unless it already ended otherwise); returns at once.
  void close();
  /// The presenter calls this once the picture it drew from the frames next() last gave is handed
  /// to the display (after the window's buffer swap, the headset's xrEndFrame, the headless
  /// target's finish): the first call after a next() that took new frames times the "presented"
  /// stage (stage_stats.hpp) of that frame set; later calls do nothing.
  void presented();
  /// A copy of the newest live figures.
  LiveStats live() const;

 private:
  State& state_;
};

/// The viewpoint a viewer starts from: orbit_view around the first camera, over the points of
/// `frames` (null entries skipped; built on the CPU, once). Camera i of `frames` is `cameras[i]`.
ViewCamera default_view(std::span<const CameraCalibration> cameras,
                        std::span<const std::shared_ptr<const CameraFrame>> frames);

/// A headless presenter's steady draw rate: take() takes the feed's new frames, waiting at most
/// until the next draw time (1/fps apart; after a stall the next one is a period later, never a
/// bunch at once), and says whether that time has come. The frames are always taken, so the
/// feed knows its end was seen (FrameFeed::finished()).
class DrawPace {
 public:
  /// `fps` at least 0.5.
  explicit DrawPace(double fps);
  /// Takes new frames into `frames`; true when a draw is due now (the next is then scheduled).
  bool take(FrameFeed& feed, std::vector<std::shared_ptr<const CameraFrame>>& frames);

 private:
  std::chrono::steady_clock::duration period_;
  std::chrono::steady_clock::time_point next_;
};

}  // namespace volcast
