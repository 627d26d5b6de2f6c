#pragma once
// The volcast subcommands. Each returns the process exit code; errors are thrown as volcast::Error
// and reported by main.
#include <atomic>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace volcast {

/// Set by SIGINT/SIGTERM; long-running commands stop cleanly when it becomes true.
extern std::atomic<bool> g_interrupted;

struct ServeArgs {
  std::vector<std::string> sources;
  std::string bind = "127.0.0.1";
  uint16_t port = 7300;
  double fps = 30;
  std::string intrinsics;  ///< "fx,fy,cx,cy" for image sequences without intrinsics.json
  int key_frame_interval = 60;
  double seconds = 0;  ///< 0 = until interrupted
};
int run_serve(const ServeArgs& args);

struct ViewArgs {
  std::string connect;
  std::string depth_codec = "rvl", color_codec = "jpeg";
  bool headless = false, no_render = false;
  int frames = 0;
  double seconds = 0;
  std::string screenshot, save_frames, stats_json;
  std::string size = "1280x720";
  std::string eye, target;
};
int run_view(const ViewArgs& args);

struct DemoArgs {
  double seconds = 5;
  std::string out = "out/demo";
  std::string
      data;  ///< folder holding the shared recordings; default: found near the binary or cwd
  std::string depth_codec = "rvl", color_codec = "jpeg";
};
int run_demo(const DemoArgs& args);

struct InfoArgs {
  std::string file;
  bool json = false;
};
int run_info(const InfoArgs& args);

}  // namespace volcast
