#pragma once
// The receiver pipeline: receive and decode (the cameras in parallel), hand the decoded images to
// the render thread (a Presenter: headless by default, a window or a headset from src/viewer/),
// which uploads them and reconstructs the points on the GPU (CameraRenderer: no per-point CPU
// work), and measure what arrived and what each stage cost.
#include <atomic>
#include <chrono>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "volcast/core/error.hpp"
#include "volcast/net/client.hpp"
#include "volcast/pipeline/stage_stats.hpp"
#include "volcast/reconstruct/avatar_filter.hpp"
#include "volcast/render/camera_renderer.hpp"
#include "volcast/render/view.hpp"
#include "volcast/session/participant.hpp"

namespace volcast {

struct ViewerResult;
class FrameFeed;

/// What the render thread does with a session: takes frames from the feed and draws them (into a
/// window, a headset's swapchain or a headless target), setting result.renderer and counting
/// result.frames_rendered. Runs on a thread of its own until feed.finished() (or it calls
/// feed.close()); an exception it throws ends the session (ViewerEnd::kError, "renderer: ...").
using Presenter = std::function<void(FrameFeed& feed, ViewerResult& result)>;

struct ViewerOptions {
  ClientConfig client;
  int frames = 0;                           ///< stop after this many frame sets (0 = no limit)
  double seconds = 0;                       ///< stop after this long (0 = no limit)
  bool render = true;                       ///< render (presenter, else headless with EGL)
  Presenter presenter;                      ///< the render thread; empty: headless (below)
  int width = 1280, height = 720;           ///< headless render size, pixels
  double software_render_fps = 0;           ///< with a software rasteriser (no GPU), draw at most
                                            ///< this often (0 = every frame set)
  std::optional<ViewCamera> view;           ///< default: orbit_view from the site's first camera
  CameraPassOptions pass;                   ///< headless: surface, splat size, blending, looks
  AvatarFilter avatar_filter;               ///< headless: points drawn; default: all
  std::filesystem::path screenshot;         ///< headless: PNG of the last render, if set
  std::filesystem::path save_frames_dir;    ///< decoded depth/color PNGs per frame, if set
  std::filesystem::path stats_json;         ///< statistics as JSON, if set
  const std::atomic<bool>* stop = nullptr;  ///< optional external stop flag
  /// Called once connected, before anything is received, on the calling thread (a participant
  /// joins its session here: SessionClient::start).
  std::function<void(Client&)> on_connected;
  /// Called once receiving has ended, before the figures are written, on the calling thread (a
  /// participant stops and adds its session figures to the result).
  std::function<void(ViewerResult&)> on_finished;
};

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

/// Why a viewer's session ended. The first four are normal ends; from kTimedOut on, errors.
enum class ViewerEnd {
  kFramesReached,   ///< ViewerOptions::frames frame sets received
  kSecondsReached,  ///< ViewerOptions::seconds passed
  kInterrupted,     ///< the external stop flag was set (Ctrl-C)
  kClosed,          ///< the presenter closed the session (the user closed the window)
  kServerClosed,    ///< the server closed the connection between messages
  kTimedOut,        ///< the server was silent past the handshake or receive timeout
  kRejected,        ///< the server refused the viewer (Reject)
  kProtocolError,   ///< a malformed or oversized message, a frame of the wrong size
  kConnectionLost,  ///< the connection broke
  kError,           ///< anything else: cannot connect, unknown codec, the renderer failed, ...
};
/// "frames_reached", "seconds_reached", "interrupted", "closed", "server_closed", "timed_out",
/// "rejected", "protocol_error", "connection_lost", "error".
const char* to_string(ViewerEnd end);

struct ViewerResult {
  ViewerEnd ended = ViewerEnd::kServerClosed;
  std::string error;  ///< what went wrong, for the error ends; empty otherwise
  uint64_t frame_sets_received = 0;
  std::string depth_codec, color_codec;
  std::vector<CameraStats> cameras;
  uint64_t frames_rendered = 0;
  uint64_t frames_undecodable = 0;   ///< skipped: a delta without its reference (key requested)
  std::vector<StageLatency> stages;  ///< per-stage latency, kStageNames order
  std::string renderer;              ///< GL renderer string, empty when not rendering
  /// The last frame set's decoded images, per camera (null for a camera that sent none).
  std::vector<std::shared_ptr<const CameraFrame>> last_frames;
  /// A participant's session figures (round trip, the others' pose rates and ages, avatar
  /// latency) and the session it was in; absent for a plain viewer.
  std::optional<ParticipantStats> session;
  std::string session_name;
};

/// Figures while the session runs, for a viewer's panel: refreshed about twice a second by the
/// receiving thread. Per camera, frames_received and frames_dropped count from the start; fps,
/// Mbit/s and latency cover the last refresh interval. Stages cover the session so far.
struct LiveStats {
  std::vector<CameraStats> cameras;
  std::vector<StageLatency> stages;  ///< kStageNames order; empty until a frame set arrived
  std::string depth_codec, color_codec;
  uint64_t frame_sets_received = 0;
};

/// The render thread's side of a running session (see Presenter). Thread-safe.
class FrameFeed {
 public:
  struct State;  // receiver.cpp
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
  /// A copy of the newest live figures.
  LiveStats live() const;

 private:
  State& state_;
};

/// Thrown by run_viewer when the session ended on an error (ViewerEnd kTimedOut and after):
/// what() is the reason, result() the figures up to then.
class ViewerError : public Error {
 public:
  ViewerError(const std::string& message, std::shared_ptr<const ViewerResult> result)
      : Error(message), result_(std::move(result)) {}
  const ViewerResult& result() const { return *result_; }

 private:
  std::shared_ptr<const ViewerResult> result_;
};

/// Connects, receives until a limit is reached or the server closes, and returns the figures
/// (`ended` says which). On every end, errors included (a failed connection or handshake, a
/// timeout, a protocol error, a failed renderer), the figures go to `stats_json` when it is set;
/// an error then throws ViewerError carrying them.
ViewerResult run_viewer(const ViewerOptions& options);

/// The headless presenter run_viewer uses when options.presenter is empty: an EGL target of
/// options.width x height, CameraRenderer with options.pass and options.avatar_filter from
/// options.view (default orbit_view), throttled to software_render_fps on a software rasteriser,
/// and options.screenshot written from the last frame.
Presenter headless_presenter(const ViewerOptions& options);

/// The viewpoint a viewer starts from: orbit_view around the first camera, over the points of
/// `frames` (null entries skipped; built on the CPU, once). Camera i of `frames` is `cameras[i]`.
ViewCamera default_view(std::span<const CameraCalibration> cameras,
                        std::span<const std::shared_ptr<const CameraFrame>> frames);

/// Writes the figures as JSON ({"ended", "error" (null when none), "frame_sets_received",
/// "depth_codec", "color_codec", "frames_rendered", "cameras": [...], "stages": [{"stage",
/// "p50_ms", "p99_ms", "mean_ms"}, ...]}; for a participant also "session" (name), "participants"
/// (the others' names), "session_round_trip_ms_p50" / "_p99", "round_trip_samples", "poses_sent",
/// "avatar_frames_sent" and per other participant {"id", "name", "poses_received",
/// "pose_rate_hz", "pose_age_ms_p50", "pose_age_ms_p99", "avatar_frames_received", "avatar_fps",
/// "avatar_latency_ms_p50", "avatar_latency_ms_p99"} in "others").
void write_stats_json(const std::filesystem::path& path, const ViewerResult& result);
/// A short human-readable table of the figures, with the per-stage latencies and how the session
/// ended.
std::string format_stats_table(const ViewerResult& result);

}  // namespace volcast
