// volcast demo, first part: the real recordings streamed over TLS on loopback to one viewer,
// rendered from above and from each camera, with the viewer's latency table.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstdlib>
#include <nlohmann/json.hpp>

#include "volcast/capture/real_sites.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/image_io.hpp"
#include "volcast/demo/demo.hpp"
#include "volcast/pipeline/receiver.hpp"
#include "volcast/pipeline/sender.hpp"
#include "volcast/render/camera_renderer.hpp"
#include "volcast/render/headless_target.hpp"

namespace volcast {
namespace fs = std::filesystem;

int run_demo(const DemoArgs& a) {
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
  spdlog::info("demo: server on 127.0.0.1:{} (TLS 1.3, join token), viewer for {} s ({})",
               server.port(), a.seconds,
               a.tier_pinned ? "tier " + to_string(a.tier) + ", pinned"
                             : "adapting along the server's tier ladder");

  ViewerOptions opt;
  opt.client = client_config_from_link(server.join_link("127.0.0.1"));
  opt.client.tier = a.tier;
  opt.client.adapt = !a.tier_pinned;
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
  // The paper's splats here; render_overview_mesh.png below is the viewer's default surface.
  opt.pass.surface = Surface::kSplats;
  opt.screenshot = out / "render_overview.png";
  opt.stats_json = out / "stats.json";
  opt.stop = a.stop;
  const ViewerResult result = run_viewer(opt);
  // Each viewer as the server saw it: its tier, the path it measured, every switch and why.
  for (const ViewerReport& v : server.viewers()) {
    std::printf(
        "\nserver: viewer %llu (%s): tier %s%s, path RTT %.1f ms, delivery %.1f Mbit/s, "
        "goodput %.1f Mbit/s, queue %.0f ms, %zu tier switches\n",
        static_cast<unsigned long long>(v.id), v.peer.c_str(), to_string(v.tier).c_str(),
        v.adaptive ? fmt::format(" (adaptive, rung {})", v.rung).c_str() : " (pinned)",
        v.min_rtt_ms, v.bottleneck_mbit_s, v.goodput_mbit_s, v.queue_ms, v.switches.size());
    for (const TierSwitch& s : v.switches)
      std::printf("  %s -> %s: %s\n", s.from.c_str(), s.to.c_str(), s.reason.c_str());
  }
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
    render(overview, opt.pass, out / "render_overview.png");
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
  if (a.no_session || (a.stop && *a.stop)) return 0;
  return run_demo_session(a, *data, out);
}

}  // namespace volcast
