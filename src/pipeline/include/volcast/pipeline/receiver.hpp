#pragma once
// The receiver pipeline: receive and decode (the cameras in parallel), hand the decoded images to
// the render thread (a Presenter: headless by default, a window or a headset from src/viewer/),
// which uploads them and reconstructs the points on the GPU (CameraRenderer: no per-point CPU
// work), and measure what arrived and what each stage cost. The steps, in the order a depth frame
// takes them, are named at the top of receiver.cpp; a presenter needs only frame_feed.hpp.
#include <atomic>
#include <filesystem>
#include <functional>
#include <optional>

#include "volcast/net/stream/client.hpp"
#include "volcast/pipeline/frame_feed.hpp"
#include "volcast/pipeline/viewer_result.hpp"
#include "volcast/reconstruct/avatar_filter.hpp"
#include "volcast/render/camera_renderer.hpp"
#include "volcast/render/view.hpp"

namespace volcast {

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
  /// After a cut -- the connection broke, or nothing arrived for client.receive_timeout_ms --
  /// connect again with the same config (250 ms apart, doubling to 2 s; each try within 2 s)
  /// until it works, then call on_reconnected and resume with the server's key frame set. The
  /// panel shows "reconnecting" meanwhile. It gives up, ending as the cut did, after
  /// reconnect_give_up_s, or when the server refuses the new connection (Reject); the time limit,
  /// the stop flag and the presenter still end it at once. A site that comes back with other
  /// cameras ends it (kError).
  bool reconnect = false;
  double reconnect_give_up_s = 300;
  /// Called on the calling thread with each new connection, before it receives (a participant
  /// rejoins its session here: SessionClient::reattach). The old client still exists, closed.
  std::function<void(Client&)> on_reconnected;
  /// Frame sets older than this when they arrive (capture to received, ms) are decoded (delta
  /// frames need them) but not drawn: what queued on a path that stalled is stale (0: all drawn).
  int stale_ms = 0;
  /// Called once receiving has ended, before the figures are written, on the calling thread (a
  /// participant stops and adds its session figures to the result).
  std::function<void(ViewerResult&)> on_finished;
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

}  // namespace volcast
