#pragma once
// The desktop viewer: a GLFW window (OpenGL 4.5 core through GLX) that draws the session's cameras
// with CameraRenderer into its default framebuffer, with a Dear ImGui panel on top. It is a
// Presenter (volcast/pipeline/frame_feed.hpp): run_viewer runs it on its render thread.
//
// Each loop: poll events, take new frames from the feed (waiting up to 5 ms), upload the cameras
// whose frame changed (the same pointer is the same images), draw, draw the panel, swap. It redraws
// only when frames arrived or the user did something, and ends the session (FrameFeed::close(),
// ViewerEnd::kClosed) when the window is closed.
//
// Navigation (navigation.hpp), starting at default_view() or DesktopOptions::view:
//   left drag   orbit about the pivot       wheel        zoom toward the pivot
//   right drag  look around (fly)           W A S D Q E  fly forward/left/back/right/down/up
//   Shift       fly 4x faster               R            back to the starting view
//   F12 or P    screenshot                  H            hide/show the panel
//   Ctrl+S      save the camera poses (as the panel's Save)
//   T           in a session: the next left click on the floor teleports there
//   M           in a session with a voice link: mute / unmute your microphone
//   V (held)    in a session with push-to-talk (view --push-to-talk): talk while held
//               (voice_keys.hpp)
// The panel: surface (splats/mesh), splat size mode, point size or splat scale, mesh edge ratio,
// blending, per camera visible/tint and registration sliders (pose_sliders.hpp) with Save (writes
// the poses into DesktopOptions::site_config, site_config.hpp), avatar filters, live figures from
// FrameFeed::live() (per camera fps, latency p50, Mbit/s, frames dropped; per-stage latency; the
// codec tier) and the GL renderer. In a session: the lobby, who is there with a speaking / muted
// badge each and, with a voice link, your microphone's mute box and a volume slider per
// participant (0..4).
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "volcast/pipeline/frame_feed.hpp"
#include "volcast/pipeline/session_scene.hpp"
#include "volcast/reconstruct/avatar_filter.hpp"
#include "volcast/render/camera_renderer.hpp"
#include "volcast/render/frame_budget.hpp"
#include "volcast/render/view.hpp"
#include "volcast/voice/voice_link.hpp"

namespace volcast {

/// A key press (or release) injected by a test as if a user pressed it: handled by the same code
/// as a real one, just before drawing frame `frame` (counted as DesktopOptions::max_frames counts).
struct ScriptedKey {
  uint64_t frame = 0;
  int key = 0;           ///< a GLFW key code, e.g. GLFW_KEY_F12 (301)
  int mods = 0;          ///< GLFW modifier bits, e.g. GLFW_MOD_CONTROL (2) for Ctrl+S
  bool release = false;  ///< let the key go (a held V, push-to-talk) instead of pressing it
};

/// A left click injected by a test at window point (x, y) (screen coordinates from the top left),
/// handled like a real one just before drawing frame `frame`.
struct ScriptedClick {
  uint64_t frame = 0;
  double x = 0, y = 0;
};

/// The mouse moved to window point (x, y) (screen coordinates from the top left) by a test, and
/// a button (GLFW_MOUSE_BUTTON_LEFT 0, _RIGHT 1; -1: none, a move only) pressed or let go there,
/// handled like real input just before drawing frame `frame`.
struct ScriptedMouse {
  uint64_t frame = 0;
  double x = 0, y = 0;
  int button = -1;
  bool release = false;
  int mods = 0;  ///< GLFW modifier bits held (GLFW_MOD_SHIFT 1, GLFW_MOD_ALT 4)
};

struct DesktopOptions {
  int width = 1280, height = 720;  ///< window size, screen coordinates, 1..8192
  std::string title = "volcast";
  CameraPassOptions pass;  ///< initial panel settings
  /// kAuto: blending (pass.blend) goes off for the session once frames take too long with it
  /// (FrameBudget: each frame timed from the start of its drawing to the return of the swap,
  /// which waits for the display); the panel and result.blend_off say why, and its box turns it
  /// back on. kOn: never turned off. kOff: pass.blend starts off.
  BlendPolicy blend = BlendPolicy::kAuto;
  /// The display's frame period (µs) the budget holds frames to; 0: the primary monitor's
  /// refresh rate (60 Hz where it reports none).
  int64_t frame_period_us = 0;
  AvatarFilter avatar_filter;      ///< initial avatar filters
  std::optional<ViewCamera> view;  ///< starting view; default: default_view()
  /// Where the screenshot key writes (overwritten by each press). Empty: volcast-screenshot-<n>.png
  /// in the working directory, n the smallest number >= 1 not taken. The picture is the scene
  /// without the panel, at the framebuffer's size, top row first.
  std::filesystem::path screenshot;
  /// The screenshot as the window shows it, with the panel over the scene (for docs and tests).
  bool screenshot_panel = false;
  /// Where the panel's Save writes the cameras' world_from_camera (site_config.hpp).
  std::filesystem::path site_config = "volcast-site.json";
  std::vector<ScriptedKey> script;    ///< key presses for tests
  std::vector<ScriptedClick> clicks;  ///< left clicks for tests (teleport mode)
  std::vector<ScriptedMouse> mouse;   ///< mouse moves and buttons for tests, in frame order
  /// Close the window (ending the session) after this many frames drawn, 0 = never. Frames are
  /// counted from the first drawn with images of the stream (earlier ones show nothing).
  uint64_t max_frames = 0;
  /// A participant of a virtual-OR session (volcast view --join), or empty: a plain viewer. With
  /// one, the window draws the SessionScene (room, avatars, the site in the room) from an eye
  /// that starts at the participant's head and publishes the eye as its head pose every frame
  /// (the paper's mouse-and-keyboard fallback); the panel shows the lobby and who is there, T
  /// (or the panel's box) then a left click on the floor teleports there.
  std::function<Participant*()> participant;
  SessionSceneOptions scene;  ///< with a participant: avatar radius, room
  /// With a participant: its voice link (volcast view --join --mic/--speaker), read every frame;
  /// empty, or returning null (no link, or not made yet): no voice controls, and the panel still
  /// shows who is muted and who sends voice. The link must outlive the presenter. The window's M
  /// and V keys and the panel's mute box and volume sliders act on it (voice_controls.hpp).
  std::function<voice::VoiceLink*()> voice;
};

/// Whether a window can be opened: GLFW initialises (an X display is reachable). On false, `why`
/// (if not null) says why in a few words, e.g. "X11: The DISPLAY environment variable is missing".
/// Throws nothing.
bool desktop_available(std::string* why);

/// The desktop viewer as a Presenter. The presenter throws Error (ending the session with
/// ViewerEnd::kError) if GLFW cannot start, the window or its OpenGL 4.5 core context cannot be
/// made, or drawing fails; a screenshot or Save that fails is logged and shown in the panel.
Presenter desktop_presenter(const DesktopOptions& options);

}  // namespace volcast
