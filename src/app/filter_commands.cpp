// volcast filter and background: the filter chain on a recording.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>

#include "cli.hpp"
#include "commands.hpp"
#include "options.hpp"
#include "volcast/capture/source.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/image_io.hpp"

namespace volcast {
namespace fs = std::filesystem;
namespace {

SourceOptions source_options(const std::string& intrinsics) {
  SourceOptions o;
  if (!intrinsics.empty()) o.intrinsics = parse_pinhole(intrinsics);
  return o;
}

// False colour for a person to look at: near = red, far = blue (a "jet" ramp over [lo, hi] mm);
// invalid = black.
void false_colour(const DepthImage& d, uint16_t lo, uint16_t hi, ColorImage& out, int x_offset) {
  for (int y = 0; y < d.height; ++y)
    for (int x = 0; x < d.width; ++x) {
      uint8_t* p = out.pixel(x + x_offset, y);
      const uint16_t v = d.at(x, y);
      p[3] = 255;
      if (v == 0) {
        p[0] = p[1] = p[2] = 0;
        continue;
      }
      const float t = std::clamp(
          (static_cast<float>(v) - lo) / std::max(1.0f, static_cast<float>(hi - lo)), 0.0f, 1.0f);
      auto ramp = [](float c) {
        return static_cast<uint8_t>(255 * std::clamp(1.5f - std::abs(4 * c), 0.0f, 1.0f));
      };
      p[2] = ramp(t - 0.25f);  // red for near
      p[1] = ramp(t - 0.5f);
      p[0] = ramp(t - 0.75f);  // blue for far
    }
}

std::pair<uint16_t, uint16_t> depth_range(const DepthImage& d) {
  std::vector<uint16_t> v;
  for (uint16_t x : d.pixels)
    if (x) v.push_back(x);
  if (v.empty()) return {0, 1};
  std::sort(v.begin(), v.end());
  return {v[v.size() * 2 / 100], v[v.size() * 98 / 100]};
}

double invalid_share(const DepthImage& d) {
  size_t n = 0;
  for (uint16_t v : d.pixels) n += v == 0;
  return static_cast<double>(n) / static_cast<double>(d.size());
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

  // Per-pixel statistics over time of the depth entering the Kalman filter ("before") and leaving
  // it ("after"); invalid shares entering and leaving hole filling.
  const Intrinsics& k = chain.output_intrinsics();
  const size_t n = static_cast<size_t>(k.width) * k.height;
  std::vector<double> sum_pre(n), sq_pre(n), sum_post(n), sq_post(n);
  std::vector<uint16_t> lo(n, 65535), hi(n, 0);
  std::vector<int> valid_frames(n, 0);
  DepthImage pre_kalman, previous_pre;
  double invalid_before_fill = 0, invalid_after_fill = 0, candidate_before = 0;
  std::vector<double> moving_errors;
  CameraFrame raw, filtered;
  const std::vector<int> snapshots = {0, frames / 2, frames - 1};
  for (int f = 0; f < frames; ++f) {
    raw = source->next();
    chain.apply(raw, filtered, [&](int stage, const DepthImage& d) {
      if (stage < 4) candidate_before = invalid_share(d);
      if (stage == 4) {
        invalid_before_fill += candidate_before;
        invalid_after_fill += invalid_share(d);
      }
      if (stage < 5) pre_kalman = d;
    });
    for (size_t i = 0; i < n; ++i) {
      const uint16_t p = pre_kalman.pixels[i], q = filtered.depth.pixels[i];
      if (p == 0) continue;
      ++valid_frames[i];
      sum_pre[i] += p, sq_pre[i] += double(p) * p, sum_post[i] += q, sq_post[i] += double(q) * q;
      lo[i] = std::min(lo[i], p), hi[i] = std::max(hi[i], p);
      // A pixel that truly moved (> 20 mm since the last frame): how far is the output from it?
      if (f > 0 && previous_pre.pixels[i] && std::abs(int(p) - int(previous_pre.pixels[i])) > 20)
        moving_errors.push_back(std::abs(double(q) - double(p)));
    }
    std::swap(previous_pre, pre_kalman);
    if (std::find(snapshots.begin(), snapshots.end(), f) != snapshots.end()) {
      const auto [dlo, dhi] = depth_range(raw.depth);
      ColorImage image(raw.depth.width + filtered.depth.width,
                       std::max(raw.depth.height, filtered.depth.height));
      for (size_t i = 3; i < image.bgra.size(); i += 4)
        image.bgra[i] = 255;  // opaque black margins
      false_colour(raw.depth, dlo, dhi, image, 0);
      false_colour(filtered.depth, dlo, dhi, image, raw.depth.width);
      write_color_png(out / fmt::format("frame{:04d}_before_after.png", f), image);
    }
  }

  // Static pixels: valid in every frame and never moving more than 50 mm.
  double noise_pre = 0, noise_post = 0;
  size_t static_pixels = 0;
  for (size_t i = 0; i < n; ++i) {
    if (valid_frames[i] != frames || frames < 2 || hi[i] - lo[i] > 50) continue;
    const double m1 = sum_pre[i] / frames, m2 = sum_post[i] / frames;
    noise_pre += std::sqrt(std::max(0.0, sq_pre[i] / frames - m1 * m1));
    noise_post += std::sqrt(std::max(0.0, sq_post[i] / frames - m2 * m2));
    ++static_pixels;
  }
  if (static_pixels) {
    noise_pre /= static_cast<double>(static_pixels);
    noise_post /= static_cast<double>(static_pixels);
  }
  std::sort(moving_errors.begin(), moving_errors.end());
  double mean_moving = 0;
  for (double e : moving_errors) mean_moving += e;
  if (!moving_errors.empty()) mean_moving /= static_cast<double>(moving_errors.size());
  const double p99_moving =
      moving_errors.empty() ? 0 : moving_errors[moving_errors.size() * 99 / 100];

  nlohmann::json j = {
      {"source", a.source},
      {"frames", frames},
      {"output", {{"width", k.width}, {"height", k.height}}},
      {"hole_filling", config.hole_filling.has_value()},
      {"invalid_share_before_hole_filling", invalid_before_fill / frames},
      {"invalid_share_after_hole_filling", invalid_after_fill / frames},
      {"kalman", config.kalman.has_value()},
      {"static_pixels", static_pixels},
      {"temporal_noise_mm_before_kalman", noise_pre},
      {"temporal_noise_mm_after_kalman", noise_post},
      {"moving_pixel_samples", moving_errors.size()},
      {"moving_pixel_error_mm_mean", mean_moving},
      {"moving_pixel_error_mm_p99", p99_moving},
      {"moving_pixel_error_mm_max", moving_errors.empty() ? 0.0 : moving_errors.back()}};
  std::ofstream(out / "quality.json") << j.dump(2) << "\n";
  std::printf("%s: %d frames, %dx%d after lens correction/crop\n", a.source.c_str(), frames,
              k.width, k.height);
  if (config.hole_filling)
    std::printf("  invalid pixels         %6.2f %% before hole filling, %6.2f %% after\n",
                100 * invalid_before_fill / frames, 100 * invalid_after_fill / frames);
  if (config.kalman)
    std::printf(
        "  temporal noise         %6.2f mm before Kalman, %6.2f mm after (std over time, %zu "
        "static px)\n"
        "  moving pixels (>20 mm) %6.2f mm mean |output - input|, p99 %.1f mm (%zu samples)\n",
        noise_pre, noise_post, static_pixels, mean_moving, p99_moving, moving_errors.size());
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
