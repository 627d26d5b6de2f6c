#pragma once
// The OR display on the OR's wall monitor (issue 36, item 3): a GLFW window, windowed or full
// screen, showing what pipeline/or_display.hpp draws -- a site camera's own image from its exact
// viewpoint with the remote participants' avatars, their pointers and the session's annotations
// drawn in and hidden by the live depth -- turned upright (upright_quarter_turns), scaled to fill
// the window with its aspect ratio kept (black bars), with the labels' text over their pins and a
// small legend of who is there in which colour. It is a Presenter (pipeline/frame_feed.hpp): the
// viewer runs it on its render thread; `volcast view --join S --or-display N` opens it.
//
// It redraws when a new frame of its camera arrives and at least every 1/30 s (the others point
// and move on their own); vsync paces it.
//   F11 or F   full screen on the window's monitor (the primary one at first) / back
//   Esc        leave full screen
//   H          hide / show the legend
//   F12 or P   screenshot: the window as it shows, legend and labels included
//   closing    ends the session (FrameFeed::close(), ViewerEnd::kClosed)
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "volcast/pipeline/frame_feed.hpp"
#include "volcast/session/participant.hpp"
#include "volcast/viewer/desktop.hpp"

namespace volcast {

struct OrDisplayWindowOptions {
  size_t camera = 0;               ///< the site camera shown (index into the Welcome's cameras)
  int width = 1280, height = 720;  ///< the window's size when not full screen, 1..8192
  bool fullscreen = false;         ///< start full screen on the primary monitor
  std::string title = "volcast: OR display";
  /// The OR display's participant once joined (null before): what it sees is drawn. Required.
  std::function<Participant*()> participant;
  /// Where F12 / P write; empty: volcast-screenshot-<n>.png as the desktop viewer's.
  std::filesystem::path screenshot;
  std::vector<ScriptedKey> script;  ///< key presses for tests, by frame drawn
  /// Close the window after this many frames drawn with the camera's picture, 0 = never.
  uint64_t max_frames = 0;
};

/// The OR display's window as a Presenter. The presenter throws Error (ending the session with
/// ViewerEnd::kError) if the site has no camera options.camera, GLFW cannot start, the window or
/// its OpenGL 4.5 core context cannot be made, or drawing fails; a screenshot that fails is logged.
Presenter or_display_window_presenter(const OrDisplayWindowOptions& options);

}  // namespace volcast
