// `volcast bench --render`: the camera renderer's cost per frame, headless, on the real
// four-camera set (issue 11's render benchmark).
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>

#include "volcast/bench/bench.hpp"
#include "volcast/capture/real_sites.hpp"
#include "volcast/core/error.hpp"
#include "volcast/render/camera_renderer.hpp"
#include "volcast/render/headless_target.hpp"

namespace volcast {
namespace {

using Clock = std::chrono::steady_clock;

struct Config {
  Surface surface;
  bool blend;
  int cameras;
  int width, height, eyes;  // per eye
};

// The cameras of the four-camera set, all turned about one pivot 2 m in front of the first, so
// their surfaces overlap on screen as an operating room's cameras around one table do (the set
// has no extrinsics; the cost depends on how much is drawn, not on where).
std::vector<CameraCalibration> around_one_pivot(std::vector<CameraCalibration> cams) {
  const Eigen::Vector3d pivot(0, 0, 2.0);
  const double yaw_deg[] = {0, 12, -12, 24};
  for (size_t i = 0; i < cams.size(); ++i) {
    const Eigen::Matrix3d turn =
        Eigen::AngleAxisd(yaw_deg[i % 4] * M_PI / 180, Eigen::Vector3d::UnitY()).toRotationMatrix();
    cams[i].world_from_camera.rotation = turn;
    cams[i].world_from_camera.translation = pivot - turn * pivot;
  }
  return cams;
}

// The views of one frame: a 60-degree mono view, or two eyes 64 mm apart with 90-degree
// symmetric fields of view; from 0.4 m behind the first camera.
std::vector<View> views(const Config& c) {
  std::vector<View> v;
  for (int eye = 0; eye < c.eyes; ++eye) {
    const double x = c.eyes == 1 ? 0.0 : (eye == 0 ? -0.032 : 0.032);
    View view;
    view.world_from_view = look_at({x, 0, -0.4}, {x, 0, 2.0}, {0, -1, 0});
    view.clip_from_view =
        c.eyes == 1
            ? perspective(60, static_cast<float>(c.width) / static_cast<float>(c.height), 0.05f, 50)
            : perspective_from_tangents(-1, 1, 1, -1, 0.05f, 50);
    v.push_back(view);
  }
  return v;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

}  // namespace

int run_render_bench(const BenchArgs& a) {
  const auto data = find_data(a.data);
  if (!data) throw Error("bench --render: the real recordings were not found (--data DIR)");
  if (!(a.render_seconds > 0)) throw Error("--render-seconds must be positive");
  auto sources = four_camera_site(*data);
  std::vector<CameraCalibration> calibrations;
  std::vector<CameraFrame> frames;
  for (auto& s : sources) {
    calibrations.push_back(s->calibration());
    frames.push_back(s->next());
  }
  calibrations = around_one_pivot(calibrations);

  struct Measured {
    double ms = 0, upload_ms = 0, first_draw_ms = 0;
    size_t frames = 0;
  };
  std::string gpu;
  // Draws cameras first .. first + c.cameras - 1 with configuration c.
  const auto measure = [&](const Config& c, size_t first) {
    HeadlessTarget target(c.width * c.eyes, c.height);  // the eyes side by side
    CameraRenderer renderer;
    gpu = renderer.gl_description();
    renderer.set_cameras(std::span(calibrations).subspan(first, static_cast<size_t>(c.cameras)));
    CameraPassOptions options;
    options.surface = c.surface;
    options.blend = c.blend;
    const std::vector<View> eye_views = views(c);
    const auto draw = [&] {
      for (int eye = 0; eye < c.eyes; ++eye)
        renderer.draw_cameras(eye_views[eye],
                              {target.target().framebuffer, eye * c.width, 0, c.width, c.height},
                              options);
      target.finish();
    };
    // Uploads: every camera's new images, as each frame set arrives, and the first draw after
    // them (the mesh picks its triangles there, once per new image).
    draw();  // warm-up: shaders, the mesh's buffers, the blending framebuffer
    std::vector<double> upload_ms, first_draw_ms;
    for (int i = 0; i < 3; ++i) {
      const auto t0 = Clock::now();
      for (size_t k = 0; k < static_cast<size_t>(c.cameras); ++k)
        renderer.upload(k, frames[first + k]);
      target.finish();
      const auto t1 = Clock::now();
      draw();
      upload_ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
      first_draw_ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t1).count());
    }
    std::vector<double> ms;
    const auto start = Clock::now();
    while (ms.size() < 3 ||
           (ms.size() < 500 &&
            Clock::now() - start < std::chrono::duration<double>(a.render_seconds))) {
      const auto t0 = Clock::now();
      draw();
      ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    }
    return Measured{median(ms), median(upload_ms), median(first_draw_ms), ms.size()};
  };

  std::printf("%-7s %-6s %-8s %-11s %5s %12s %10s %14s %17s\n", "surface", "blend", "cameras",
              "size", "eyes", "ms / frame", "upload ms", "/ sum alone", "1st after upload");
  nlohmann::json rows = nlohmann::json::array();
  size_t done = 0;
  const size_t groups = 8;
  for (int eyes : {1, 2})
    for (Surface surface : {Surface::kSplats, Surface::kMesh})
      for (bool blend : {true, false}) {
        Config c{surface, blend, 1, eyes == 1 ? 1280 : 2160, eyes == 1 ? 720 : 2160, eyes};
        if (isatty(STDERR_FILENO))
          std::fprintf(stderr, "[%zu/%zu] %s%s, %dx%d x %d...\r", ++done, groups,
                       to_string(surface), blend ? " blended" : "", c.width, c.height, eyes);
        // Each camera alone: the linear baseline for several.
        std::vector<Measured> alone;
        for (size_t k = 0; k < calibrations.size(); ++k) alone.push_back(measure(c, k));
        for (int cameras : {1, 2, 4}) {
          c.cameras = cameras;
          const Measured m = cameras == 1 ? alone[0] : measure(c, 0);
          double sum_alone = 0;
          for (int k = 0; k < cameras; ++k) sum_alone += alone[static_cast<size_t>(k)].ms;
          std::printf("%-7s %-6s %-8d %-11s %5d %12.2f %10.2f %13.2fx %17.2f\n", to_string(surface),
                      blend ? "yes" : "no", cameras,
                      fmt::format("{}x{}", c.width, c.height).c_str(), eyes, m.ms, m.upload_ms,
                      m.ms / sum_alone, m.first_draw_ms);
          std::fflush(stdout);
          rows.push_back({{"renderer", to_string(surface)},
                          {"blend", blend},
                          {"cameras", cameras},
                          {"width", c.width},
                          {"height", c.height},
                          {"eyes", eyes},
                          {"ms_per_frame", m.ms},
                          {"frames_timed", m.frames},
                          {"upload_ms", m.upload_ms},
                          {"first_draw_after_upload_ms", m.first_draw_ms},
                          {"ms_sum_of_cameras_alone", sum_alone},
                          {"gpu", gpu}});
        }
      }
  std::printf(
      "renderer: %s\nms / frame: median over the frames drawn (glFinish after each), "
      "both eyes together for stereo; upload: all cameras' depth and color; / sum alone: ms "
      "over the sum of each of those cameras drawn alone (<= 1: cost grows at most linearly); "
      "1st after upload: the first frame drawn after new images (the mesh picks its triangles "
      "there)\n",
      gpu.c_str());
  if (!a.json.empty()) {
    std::ofstream out(a.json);
    out << nlohmann::json{{"render", rows}}.dump(2) << "\n";
    if (!out) throw Error("cannot write '" + a.json + "'");
    std::printf("wrote %s\n", a.json.c_str());
  }
  return 0;
}

}  // namespace volcast
