// How much a FilterChain does to a recording (filter_report.hpp).
#include "volcast/filter/filter_report.hpp"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <vector>

#include "volcast/core/error.hpp"

namespace volcast {
namespace {

// A "jet" ramp over [lo, hi] mm: near red, far blue; invalid black. Into columns x_offset.. of
// `out`.
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

// The 2nd and 98th percentile of the valid depth (mm); {0, 1} without any.
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

FilterReport measure_filter(
    FilterChain& chain, const FilterConfig& config, const std::function<void(CameraFrame&)>& next,
    int frames, const std::function<void(int, const CameraFrame&, const CameraFrame&)>& snapshot) {
  if (frames < 1)
    throw Error("filter: at least one frame is needed, not " + std::to_string(frames));
  FilterReport r;
  r.frames = frames;
  r.hole_filling = config.hole_filling.has_value();
  r.kalman = config.kalman.has_value();
  // Per-pixel statistics over time of the depth entering the Kalman filter ("before") and leaving
  // it ("after"); invalid shares entering and leaving hole filling.
  const Intrinsics& k = chain.output_intrinsics();
  r.width = k.width;
  r.height = k.height;
  const size_t n = static_cast<size_t>(k.width) * k.height;
  std::vector<double> sum_pre(n), sq_pre(n), sum_post(n), sq_post(n);
  std::vector<uint16_t> lo(n, 65535), hi(n, 0);
  std::vector<int> valid_frames(n, 0);
  DepthImage pre_kalman, previous_pre;
  double candidate_before = 0;
  std::vector<double> moving_errors;
  CameraFrame raw, filtered;
  for (int f = 0; f < frames; ++f) {
    next(raw);
    chain.apply(raw, filtered, [&](int stage, const DepthImage& d) {
      if (stage < 4) candidate_before = invalid_share(d);
      if (stage == 4) {
        r.invalid_before_fill += candidate_before;
        r.invalid_after_fill += invalid_share(d);
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
    if (snapshot && (f == 0 || f == frames / 2 || f == frames - 1)) snapshot(f, raw, filtered);
  }
  r.invalid_before_fill /= frames;
  r.invalid_after_fill /= frames;
  // Static pixels: valid in every frame and never moving more than 50 mm.
  for (size_t i = 0; i < n; ++i) {
    if (valid_frames[i] != frames || frames < 2 || hi[i] - lo[i] > 50) continue;
    const double m1 = sum_pre[i] / frames, m2 = sum_post[i] / frames;
    r.noise_before_mm += std::sqrt(std::max(0.0, sq_pre[i] / frames - m1 * m1));
    r.noise_after_mm += std::sqrt(std::max(0.0, sq_post[i] / frames - m2 * m2));
    ++r.static_pixels;
  }
  if (r.static_pixels) {
    r.noise_before_mm /= static_cast<double>(r.static_pixels);
    r.noise_after_mm /= static_cast<double>(r.static_pixels);
  }
  std::sort(moving_errors.begin(), moving_errors.end());
  r.moving_samples = moving_errors.size();
  for (double e : moving_errors) r.moving_mean_mm += e;
  if (!moving_errors.empty()) {
    r.moving_mean_mm /= static_cast<double>(moving_errors.size());
    r.moving_p99_mm = moving_errors[moving_errors.size() * 99 / 100];
    r.moving_max_mm = moving_errors.back();
  }
  return r;
}

ColorImage before_after_picture(const DepthImage& before, const DepthImage& after) {
  const auto [lo, hi] = depth_range(before);
  ColorImage image(before.width + after.width, std::max(before.height, after.height));
  for (size_t i = 3; i < image.bgra.size(); i += 4) image.bgra[i] = 255;  // opaque black margins
  false_colour(before, lo, hi, image, 0);
  false_colour(after, lo, hi, image, before.width);
  return image;
}

std::string to_json(const FilterReport& r, const std::string& source) {
  const nlohmann::json j = {{"source", source},
                            {"frames", r.frames},
                            {"output", {{"width", r.width}, {"height", r.height}}},
                            {"hole_filling", r.hole_filling},
                            {"invalid_share_before_hole_filling", r.invalid_before_fill},
                            {"invalid_share_after_hole_filling", r.invalid_after_fill},
                            {"kalman", r.kalman},
                            {"static_pixels", r.static_pixels},
                            {"temporal_noise_mm_before_kalman", r.noise_before_mm},
                            {"temporal_noise_mm_after_kalman", r.noise_after_mm},
                            {"moving_pixel_samples", r.moving_samples},
                            {"moving_pixel_error_mm_mean", r.moving_mean_mm},
                            {"moving_pixel_error_mm_p99", r.moving_p99_mm},
                            {"moving_pixel_error_mm_max", r.moving_max_mm}};
  return j.dump(2);
}

}  // namespace volcast
