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
