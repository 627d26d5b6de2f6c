#include <spdlog/spdlog.h>

#include <chrono>
#include <thread>

#include "commands.hpp"
#include "options.hpp"
#include "site.hpp"
#include "viewer.hpp"
#include "volcast/core/error.hpp"

namespace volcast {

std::atomic<bool> g_interrupted{false};

int run_serve(const ServeArgs& a) {
  SourceOptions source_options;
  if (!a.intrinsics.empty()) source_options.intrinsics = parse_pinhole(a.intrinsics);
  std::vector<std::unique_ptr<FrameSource>> sources;
  for (const auto& path : a.sources) {
    sources.push_back(open_source(path, source_options));
    const auto& k = sources.back()->calibration().depth;
    spdlog::info("camera {}: {} ({}x{}, {} frames, fx {:.1f} fy {:.1f} cx {:.1f} cy {:.1f})",
                 sources.size() - 1, sources.back()->description(), k.width, k.height,
                 sources.back()->frame_count(), k.fx, k.fy, k.cx, k.cy);
  }
  SitePlayer site(std::move(sources), a.fps);
  ServerConfig config;
  config.bind_address = a.bind;
  config.port = a.port;
  config.key_frame_interval = a.key_frame_interval;
  Server server(site.cameras(), config);
  site.start(server);
  spdlog::info("serving {} camera(s) at {} fps on {}:{} (Ctrl-C stops)", a.sources.size(), a.fps,
               a.bind, server.port());
  const auto start = std::chrono::steady_clock::now();
  auto last_report = start;
  while (!g_interrupted) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    const auto now = std::chrono::steady_clock::now();
    if (a.seconds > 0 && now - start > std::chrono::duration<double>(a.seconds)) break;
    if (now - last_report > std::chrono::seconds(5)) {
      last_report = now;
      int connected = 0;
      for (const auto& v : server.viewers()) connected += v.connected;
      spdlog::info("{} frame sets published, {} viewer(s) connected", site.frame_sets_published(),
                   connected);
    }
  }
  site.stop();
  server.stop();
  for (const auto& v : server.viewers())
    spdlog::info("viewer {} ({}/{}): {} frame sets sent, {} dropped, {:.1f} MB", v.peer,
                 v.depth_codec, v.color_codec, v.frames_sent, v.frames_dropped,
                 static_cast<double>(v.bytes_sent) / 1e6);
  return 0;
}

int run_view(const ViewArgs& a) {
  ViewerOptions opt;
  std::tie(opt.client.host, opt.client.port) = parse_host_port(a.connect);
  opt.client.depth_codec = a.depth_codec;
  opt.client.color_codec = a.color_codec;
  opt.frames = a.frames;
  opt.seconds = a.seconds;
  opt.render = !a.no_render;
  if (!a.headless && opt.render)
    spdlog::info(
        "no windowed viewer in this build yet: rendering headless (use --screenshot to see it)");
  const size_t x = a.size.find('x');
  if (x == std::string::npos) throw Error("--size expects WIDTHxHEIGHT, e.g. 1280x720");
  const auto wh = parse_numbers(a.size.substr(0, x) + "," + a.size.substr(x + 1), 2, "--size");
  opt.width = static_cast<int>(wh[0]);
  opt.height = static_cast<int>(wh[1]);
  if (!a.eye.empty() || !a.target.empty()) {
    if (a.eye.empty() || a.target.empty()) throw Error("--eye and --target go together");
    const auto e = parse_numbers(a.eye, 3, "--eye");
    const auto t = parse_numbers(a.target, 3, "--target");
    ViewCamera v;
    v.eye = Eigen::Vector3d(e[0], e[1], e[2]).cast<float>();
    v.target = Eigen::Vector3d(t[0], t[1], t[2]).cast<float>();
    opt.view = v;
  }
  opt.screenshot = a.screenshot;
  opt.save_frames_dir = a.save_frames;
  opt.stats_json = a.stats_json;
  opt.stop = &g_interrupted;
  const ViewerResult result = run_viewer(opt);
  std::printf("%s", format_stats_table(result).c_str());
  return 0;
}

}  // namespace volcast
