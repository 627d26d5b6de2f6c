#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <nlohmann/json.hpp>

#include "commands.hpp"
#include "real_sites.hpp"
#include "volcast/capture/k4a_recording.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/image_io.hpp"
#include "volcast/pipeline/receiver.hpp"
#include "volcast/pipeline/sender.hpp"
#include "volcast/render/camera_renderer.hpp"
#include "volcast/render/headless_target.hpp"

namespace volcast {
namespace fs = std::filesystem;
namespace {

// The four corners of the intrinsics line `volcast info` prints.
std::string intrinsics_line(const Intrinsics& k) {
  return fmt::format(
      "{}x{}  fx {:.4f} fy {:.4f} cx {:.4f} cy {:.4f}  k1..k6 {:.6g} {:.6g} {:.6g} {:.6g} {:.6g} "
      "{:.6g}"
      "  p1 {:.6g} p2 {:.6g}",
      k.width, k.height, k.fx, k.fy, k.cx, k.cy, k.k1, k.k2, k.k3, k.k4, k.k5, k.k6, k.p1, k.p2);
}

nlohmann::json intrinsics_json(const Intrinsics& k) {
  return {{"width", k.width},
          {"height", k.height},
          {"fx", k.fx},
          {"fy", k.fy},
          {"cx", k.cx},
          {"cy", k.cy},
          {"k1", k.k1},
          {"k2", k.k2},
          {"k3", k.k3},
          {"k4", k.k4},
          {"k5", k.k5},
          {"k6", k.k6},
          {"p1", k.p1},
          {"p2", k.p2},
          {"codx", k.codx},
          {"cody", k.cody},
          {"metric_radius", k.metric_radius}};
}

}  // namespace

int run_demo(const DemoArgs& a) {
  const auto low_latency = hold_low_latency(a.low_latency);
  const auto data = find_data(a.data);
  if (!data) {
    std::fprintf(
        stderr,
        "volcast demo: no real recordings found.\n"
        "It looks for a folder holding %s/ and %s in --data DIR, $VOLCAST_DATA,\n"
        "../shared/data next to the repository, or ./shared/data.\n"
        "Put an Azure Kinect recording (.mkv) and an image sequence (depth/*.png, color/*.jpg)\n"
        "there, or stream your own with: volcast serve --source PATH [--source PATH ...]\n",
        kHandsSet, kKinectSet);
    return 2;
  }
  spdlog::info("demo: real recordings from {}", data->string());
  const fs::path out = a.out;
  fs::create_directories(out);

  std::vector<std::unique_ptr<FrameSource>> sources =
      a.cameras == 4 ? four_camera_site(*data) : two_camera_site(*data);
  SitePlayer site(std::move(sources), 0);  // 30 fps; each recording paced at its own rate
  ServerConfig config;
  config.port = 0;  // any free loopback port; TLS 1.3 with a certificate made for this demo
  std::vector<protocol::CameraInfo> cameras = site.cameras();
  for (size_t i = 0; i < cameras.size(); ++i)
    cameras[i].description = "camera " + std::to_string(i);
  Server server(cameras, config);
  site.start(server);
  spdlog::info(
      "demo: server on 127.0.0.1:{} (TLS 1.3, join token), viewer for {} s (depth {}, "
      "color {})",
      server.port(), a.seconds, a.depth_codec, a.color_codec);

  ViewerOptions opt;
  opt.client = client_config_from_link(server.join_link("127.0.0.1"));
  opt.client.depth_codec = a.depth_codec;
  opt.client.color_codec = a.color_codec;
  opt.seconds = a.seconds;
  opt.software_render_fps = 2;  // without a GPU, llvmpipe would take both cores from the stream
  opt.render = !a.no_render;
  // Overview: behind, above and between the cameras (placed along x), looking into every scene.
  float mid_x = 0;
  for (const auto& c : site.cameras())
    mid_x += static_cast<float>(c.calibration.world_from_camera.translation.x());
  mid_x /= static_cast<float>(site.cameras().size());
  ViewCamera overview;
  overview.eye = {mid_x, -0.7f - 0.3f * mid_x, -1.4f - 0.8f * mid_x};
  overview.target = {mid_x, 0.1f, 1.4f};
  opt.view = overview;
  opt.screenshot = out / "render_overview.png";
  opt.stats_json = out / "stats.json";
  opt.stop = &g_interrupted;
  const ViewerResult result = run_viewer(opt);
  site.stop();
  server.stop();

  // Extra renders of the last frame set: from each camera's own viewpoint, and the mesh.
  const auto cams = site.cameras();
  HeadlessTarget target(1280, 720);
  CameraRenderer renderer;
  std::vector<CameraCalibration> calibrations;
  for (const auto& c : cams) calibrations.push_back(c.calibration);
  renderer.set_cameras(calibrations);
  for (size_t i = 0; i < result.last_frames.size() && i < cams.size(); ++i)
    if (result.last_frames[i]) renderer.upload(i, *result.last_frames[i]);
  ColorImage image;
  const auto render = [&](const ViewCamera& v, const CameraPassOptions& o, const fs::path& file) {
    renderer.draw_cameras(to_view(v, target.target().aspect()), target.target(), o);
    target.read_image(image);
    write_color_png(file, image);
  };
  if (a.no_render)  // the overview was not drawn while streaming: draw it now
    render(overview, {}, out / "render_overview.png");
  CameraPassOptions mesh;
  mesh.surface = Surface::kMesh;
  render(overview, mesh, out / "render_overview_mesh.png");
  for (size_t i = 0; i < cams.size(); ++i) {
    const RigidTransform& w = cams[i].calibration.world_from_camera;
    ViewCamera v;
    v.eye = w.translation.cast<float>();
    v.target = (w * Eigen::Vector3d(0, 0, 1)).cast<float>();
    v.up = (w.rotation * Eigen::Vector3d(0, -1, 0)).cast<float>();
    v.vertical_fov_deg = 65;
    render(v, {}, out / fmt::format("render_camera{}.png", i));
  }
  std::printf("\n%s", format_stats_table(result).c_str());
  std::printf("\nwrote %s, %s (splats; _mesh: the grid mesh) and render_camera0..%zu.png there\n",
              (out / "stats.json").c_str(), (out / "render_overview.png").c_str(), cams.size() - 1);
  if (a.no_session || g_interrupted) return 0;
  return run_demo_session(a, *data, out);
}

namespace {

// Reads every frame of a freshly opened source (one pass), with a progress line on stderr when a
// person watches (a terminal), as the server benchmark does.
FrameCheck check_every_frame(FrameSource& src) {
  const bool tty = isatty(STDERR_FILENO);
  int shown = -1;
  FrameCheck c = check_frames(src, [&](int done, int total) {
    const int percent = done * 100 / std::max(total, 1);
    if (!tty || percent == shown) return;
    shown = percent;
    std::fprintf(stderr, "\rchecking every frame: %d/%d (%d %%)", done, total, percent);
  });
  if (tty) std::fprintf(stderr, "\r\033[K");  // clear the progress line
  return c;
}

void add_check_json(const FrameCheck& c, nlohmann::json& j) {
  j["checked_frames"] = c.frames;
  j["bad_frame_count"] = c.bad.size();
  j["bad_frames"] = nlohmann::json::array();
  for (const auto& b : c.bad) j["bad_frames"].push_back({{"index", b.index}, {"error", b.error}});
  j["frames_without_color"] = c.frames_without_color;
}

void print_check(const FrameCheck& c) {
  constexpr size_t kListed = 50;  // --json lists every one
  std::printf("  checked %d frames: %zu cannot be read%s, %d without color\n", c.frames,
              c.bad.size(), c.bad.empty() ? "" : " (skipped when streaming)",
              c.frames_without_color);
  for (size_t i = 0; i < c.bad.size() && i < kListed; ++i)
    std::printf("    BAD frame %d: %s\n", c.bad[i].index, c.bad[i].error.c_str());
  if (c.bad.size() > kListed)
    std::printf("    ... and %zu more (--json lists all)\n", c.bad.size() - kListed);
}

}  // namespace

// Exit code 0 whenever the source opens, bad frames or not: they are listed (and counted in
// bad_frame_count) for the reader to act on; 1 if the source cannot be opened at all.
int run_info(const InfoArgs& a) {
  const fs::path path = a.file;
  if (path.extension() == ".vcr") return run_recording_info(a);
  nlohmann::json j;
  if (fs::is_directory(path)) {
    auto src = open_source(path, {});
    const auto& k = src->calibration().depth;
    const FrameCheck check = check_every_frame(*src);
    j = {{"kind", "image sequence"},
         {"path", path.string()},
         {"frames", src->frame_count()},
         {"color_frames", src->color_frame_count()},
         {"fps", src->fps()},
         {"depth_intrinsics", intrinsics_json(k)}};
    add_check_json(check, j);
    if (a.json) {
      std::printf("%s\n", j.dump(2).c_str());
    } else {
      std::printf("%s\n  frames: %d at %.1f fps, %d with a color file\n  depth intrinsics: %s\n",
                  src->description().c_str(), src->frame_count(), src->fps(),
                  src->color_frame_count(), intrinsics_line(k).c_str());
      print_check(check);
    }
    return 0;
  }
  const K4aRecordingInfo info = probe_k4a_recording(path);
  const FrameCheck check = check_every_frame(*open_source(path, {}));
  if (a.json) {
    j = {{"kind", "Azure Kinect recording"},
         {"path", path.string()},
         {"depth_mode", info.depth_mode},
         {"color_mode", info.color_mode},
         {"depth_frames", info.depth_frames},
         {"color_frames", info.color_frames},
         {"duration_s", info.duration_s},
         {"fps", info.fps},
         {"depth_intrinsics", intrinsics_json(info.depth_intrinsics)}};
    if (info.color_intrinsics.width) j["color_intrinsics"] = intrinsics_json(info.color_intrinsics);
    j["streams"] = nlohmann::json::array();
    for (const auto& s : info.streams)
      j["streams"].push_back({{"index", s.index},
                              {"title", s.title},
                              {"codec", s.codec},
                              {"width", s.width},
                              {"height", s.height}});
    add_check_json(check, j);
    std::printf("%s\n", j.dump(2).c_str());
    return 0;
  }
  std::printf("Azure Kinect recording %s\n", path.c_str());
  std::printf("  streams:\n");
  for (const auto& s : info.streams)
    std::printf("    #%d %-16s %-10s %s\n", s.index, s.title.c_str(), s.codec.c_str(),
                s.width ? fmt::format("{}x{}", s.width, s.height).c_str() : "");
  std::printf("  depth mode %s, color mode %s\n", info.depth_mode.c_str(),
              info.color_mode.empty() ? "(none)" : info.color_mode.c_str());
  std::printf("  frames: %d depth, %d color, %.0f fps, duration %.3f s\n", info.depth_frames,
              info.color_frames, info.fps, info.duration_s);
  std::printf("  depth intrinsics: %s\n", intrinsics_line(info.depth_intrinsics).c_str());
  if (info.color_intrinsics.width)
    std::printf("  color intrinsics: %s\n", intrinsics_line(info.color_intrinsics).c_str());
  print_check(check);
  return 0;
}

}  // namespace volcast
