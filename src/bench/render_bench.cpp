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
#include "volcast/render/shader_throughput.hpp"

namespace volcast {
namespace {

using Clock = std::chrono::steady_clock;

struct Config {
  Surface surface;
  bool blend;
  int cameras;
  int width, height, eyes;  // per eye
};

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
  // All turned about one point, so that their surfaces overlap on screen (the set has no
  // extrinsics; the cost depends on how much is drawn, not on where).
  calibrations = turned_to_overlap(calibrations);

  struct Measured {
    double ms = 0, upload_ms = 0, first_draw_ms = 0;
    size_t frames = 0;
    CameraPassTimes passes;  // GPU, both eyes, medians over frames drawn apart from `ms`
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
    // The passes' GPU times, from frames of their own: reading the queries waits for the GPU.
    renderer.time_passes(true);
    std::vector<double> pass_ms[6];
    for (int i = 0; i < 9; ++i) {
      CameraPassTimes sum;
      for (int eye = 0; eye < c.eyes; ++eye) {
        renderer.draw_cameras(eye_views[eye],
                              {target.target().framebuffer, eye * c.width, 0, c.width, c.height},
                              options);
        const CameraPassTimes t = renderer.last_pass_times();
        sum.updates_ms += t.updates_ms;
        sum.plain_ms += t.plain_ms;
        sum.prepass_ms += t.prepass_ms;
        sum.copy_ms += t.copy_ms;
        sum.weighted_ms += t.weighted_ms;
        sum.resolve_ms += t.resolve_ms;
      }
      const double values[6] = {sum.updates_ms, sum.plain_ms,    sum.prepass_ms,
                                sum.copy_ms,    sum.weighted_ms, sum.resolve_ms};
      for (int k = 0; k < 6; ++k) pass_ms[k].push_back(values[k]);
    }
    renderer.time_passes(false);
    const CameraPassTimes passes{median(pass_ms[0]), median(pass_ms[1]), median(pass_ms[2]),
                                 median(pass_ms[3]), median(pass_ms[4]), median(pass_ms[5])};
    return Measured{median(ms), median(upload_ms), median(first_draw_ms), ms.size(), passes};
  };

  std::printf("%-7s %-6s %-8s %-11s %5s %12s %10s %14s %17s  %s\n", "surface", "blend", "cameras",
              "size", "eyes", "ms / frame", "upload ms", "/ sum alone", "1st after upload",
              "GPU ms: clear | plain or prepass, copy, weighted, resolve");
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
          const CameraPassTimes& p = m.passes;
          const std::string passes =
              blend ? fmt::format("{:.2f} | {:.2f}, {:.2f}, {:.2f}, {:.2f}", p.updates_ms,
                                  p.prepass_ms, p.copy_ms, p.weighted_ms, p.resolve_ms)
                    : fmt::format("{:.2f} | {:.2f}", p.updates_ms, p.plain_ms);
          std::printf("%-7s %-6s %-8d %-11s %5d %12.2f %10.2f %13.2fx %17.2f  %s\n",
                      to_string(surface), blend ? "yes" : "no", cameras,
                      fmt::format("{}x{}", c.width, c.height).c_str(), eyes, m.ms, m.upload_ms,
                      m.ms / sum_alone, m.first_draw_ms, passes.c_str());
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
                          {"gpu_ms",
                           {{"clear", p.updates_ms},
                            {"plain", p.plain_ms},
                            {"prepass", p.prepass_ms},
                            {"copy", p.copy_ms},
                            {"weighted", p.weighted_ms},
                            {"resolve", p.resolve_ms}}},
                          {"gpu", gpu}});
        }
      }
  // What this GPU's rasteriser path gives against its compute path, for the same work: on a GPU
  // built for compute the camera passes above say little of a graphics card.
  nlohmann::json probes = nlohmann::json::array();
  {
    HeadlessTarget context(16, 16);
    for (int rounds : {0, 256}) {
      const ShaderThroughput t = measure_shader_throughput(2160, 2160, rounds, 5);
      std::printf(
          "shader throughput, 2160x2160, %3d rounds of a hash a pixel: fragment pass %7.2f ms, "
          "compute pass %7.2f ms: the rasteriser's path %.1fx the compute path's time%s\n",
          rounds, t.fragment_ms, t.compute_ms, t.fragment_ms / t.compute_ms,
          t.same_picture ? "" : " (THE PICTURES DIFFER)");
      probes.push_back({{"width", 2160},
                        {"height", 2160},
                        {"rounds", rounds},
                        {"fragment_ms", t.fragment_ms},
                        {"compute_ms", t.compute_ms},
                        {"same_picture", t.same_picture}});
    }
  }
  std::printf(
      "renderer: %s\nms / frame: median over the frames drawn (glFinish after each), "
      "both eyes together for stereo; upload: all cameras' depth and color; / sum alone: ms "
      "over the sum of each of those cameras drawn alone (<= 1: cost grows at most linearly); "
      "1st after upload: the first frame drawn after new images (the mesh picks its triangles "
      "there); GPU ms (timestamp queries, both eyes, median, frames of their own): the target's "
      "clear, then the plain draw or blending's passes; shader throughput: the same per-pixel "
      "work drawn by a full-screen triangle and by a compute shader (GPU time, median of 5)\n",
      gpu.c_str());
  if (!a.json.empty()) {
    std::ofstream out(a.json);
    out << nlohmann::json{{"render", rows}, {"shader_throughput", probes}}.dump(2) << "\n";
    if (!out) throw Error("cannot write '" + a.json + "'");
    std::printf("wrote %s\n", a.json.c_str());
  }
  return 0;
}

}  // namespace volcast
