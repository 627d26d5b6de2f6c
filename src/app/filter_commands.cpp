// volcast filter and background: the filter chain on a recording.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <fstream>

#include "cli.hpp"
#include "commands.hpp"
#include "options.hpp"
#include "volcast/capture/source.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/image_io.hpp"
#include "volcast/filter/filter_report.hpp"

namespace volcast {
namespace fs = std::filesystem;
namespace {

SourceOptions source_options(const std::string& intrinsics) {
  SourceOptions o;
  if (!intrinsics.empty()) o.intrinsics = parse_pinhole(intrinsics);
  return o;
}

}  // namespace

int run_filter(const FilterArgs& a) {
  auto source = open_source(a.source, source_options(a.intrinsics));
  const FilterConfig config = a.filters.to_config(0);
  if (!config.any())
    spdlog::warn("no filter enabled: pass e.g. --undistort --crop nfov --hole-fill 3 --kalman");
  FilterChain chain(source->calibration().depth, config);
  const int frames = a.frames > 0 ? a.frames : std::min(source->frame_count(), 300);
  const fs::path out = a.out;
  fs::create_directories(out);
  const FilterReport r = measure_filter(
      chain, config, [&](CameraFrame& f) { f = source->next(); }, frames,
      [&](int f, const CameraFrame& raw, const CameraFrame& filtered) {
        write_color_png(out / fmt::format("frame{:04d}_before_after.png", f),
                        before_after_picture(raw.depth, filtered.depth));
      });
  std::ofstream(out / "quality.json") << to_json(r, a.source) << "\n";
  std::printf("%s: %d frames, %dx%d after lens correction/crop\n", a.source.c_str(), frames,
              r.width, r.height);
  if (r.hole_filling)
    std::printf("  invalid pixels         %6.2f %% before hole filling, %6.2f %% after\n",
                100 * r.invalid_before_fill, 100 * r.invalid_after_fill);
  if (r.kalman)
    std::printf(
        "  temporal noise         %6.2f mm before Kalman, %6.2f mm after (std over time, %zu "
        "static px)\n"
        "  moving pixels (>20 mm) %6.2f mm mean |output - input|, p99 %.1f mm (%zu samples)\n",
        r.noise_before_mm, r.noise_after_mm, r.static_pixels, r.moving_mean_mm, r.moving_p99_mm,
        r.moving_samples);
  std::printf("  wrote %s and before/after PNGs (false colour, near = red)\n",
              (out / "quality.json").c_str());
  return 0;
}

int run_background(const BackgroundArgs& a) {
  if (a.out.empty()) throw Error("background: --out FILE.png is required");
  if (a.frames < 1) throw Error("background: --frames must be at least 1");
  auto source = open_source(a.source, source_options(a.intrinsics));
  // Learn in the geometry serve will use: lens correction and crop only.
  FilterConfig geometry;
  geometry.undistort = a.filters.undistort;
  if (!a.filters.crop.empty()) geometry.crop = parse_crop(a.filters.crop);
  FilterChain chain(source->calibration().depth, geometry);
  BackgroundModel model;
  CameraFrame frame;
  for (int f = 0; f < a.frames; ++f) {
    chain.apply(source->next(), frame);
    model.learn(frame.depth);
  }
  model.save(a.out);
  std::printf("learned the background of %s from %d frames (%dx%d), wrote %s\n", a.source.c_str(),
              a.frames, model.min_depth.width, model.min_depth.height, a.out.c_str());
  return 0;
}

void register_filter(CLI::App& app, Commands& commands) {
  auto [f, filter] = add_command<FilterArgs>(
      app, commands, run_filter, "filter",
      "Run the depth filter chain on a recording; write before/after PNGs and quality figures");
  f->add_option("--source", filter.source, "Azure Kinect .mkv or image-sequence folder")
      ->required();
  f->add_option("--out", filter.out, "Folder for PNGs and quality.json")->capture_default_str();
  f->add_option("--intrinsics", filter.intrinsics,
                "fx,fy,cx,cy for image sequences without intrinsics.json");
  f->add_option("--frames", filter.frames, "Frames to process (default: one pass, at most 300)");
  add_filter_flags(f, filter.filters, true);
}

void register_background(CLI::App& app, Commands& commands) {
  auto [b, background] = add_command<BackgroundArgs>(
      app, commands, run_background, "background",
      "Learn a camera's background (per-pixel minimum depth) from the empty room");
  b->add_option("--source", background.source, "Recording of the empty room")->required();
  b->add_option("--out", background.out, "Model file to write (16-bit PNG)")->required();
  b->add_option("--intrinsics", background.intrinsics,
                "fx,fy,cx,cy for image sequences without intrinsics.json");
  b->add_option("--frames", background.frames, "Frames to learn from")->capture_default_str();
  add_filter_flags(b, background.filters, false);
}

}  // namespace volcast
