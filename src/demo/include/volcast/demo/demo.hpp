#pragma once
// `volcast demo`: the shared real recordings (../shared/data) streamed on loopback to a viewer,
// rendered and reported; then a virtual-OR session with two scripted participants.
#include <atomic>
#include <filesystem>
#include <string>

#include "volcast/codec/tier.hpp"

namespace volcast {

struct DemoArgs {
  double seconds = 5;
  std::string out = "out/demo";
  std::string
      data;  ///< folder holding the shared recordings; default: found near the binary or cwd
  Tier tier{"volcast", "jpeg"};  ///< --depth-codec, --color-codec
  bool tier_pinned = false;  ///< --depth-codec or --color-codec given: the viewer does not adapt
  int cameras = 2;
  bool no_render = false;    ///< render only the PNGs at the end, not while streaming
  bool low_latency = false;  ///< the CLI holds the CPU wake-up latency at 0 meanwhile
  bool no_session = false;   ///< skip the virtual-OR session part
  double session_seconds = 8;
  /// The session part's site rate: the four Azure Kinects' one capture each, repeated (a still
  /// shows the same picture at any rate; the tests' sanitized builds use 5).
  double session_fps = 30;
  const std::atomic<bool>* stop = nullptr;  ///< set: stop early (the CLI's Ctrl-C flag)
};
/// Streams the real site (the two-camera or the four-camera set) over TLS on loopback to one
/// viewer for `seconds`, writes out/stats.json and renders (the overview as splats and as a mesh,
/// each camera's own view), prints the viewer's table, then runs the session part unless
/// no_session. Returns 0, or 2 (saying where it looked) when the recordings are not found; throws
/// Error when a part fails.
int run_demo(const DemoArgs& args);
/// The demo's virtual-OR session (demo_session.cpp): the registered four-camera site (registered
/// once, cached as out/site-4cam.json), two scripted participants (a camera avatar from the hands
/// sequence, a mesh avatar who teleports), a screenshot from each one's eye and its figures.
int run_demo_session(const DemoArgs& args, const std::filesystem::path& data,
                     const std::filesystem::path& out);

}  // namespace volcast
