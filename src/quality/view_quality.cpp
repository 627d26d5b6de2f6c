// Scoring a held-out view (view_quality.hpp): PSNR, SSIM, depth error, coverage, seam energy,
// and the side-by-side picture.
#include "volcast/quality/view_quality.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "volcast/core/error.hpp"

namespace volcast {
namespace {

float luma(const uint8_t* bgra) {
  return 0.114f * bgra[0] + 0.587f * bgra[1] + 0.299f * bgra[2];
}

void check_sizes(const ViewImages& v) {
  const int w = v.real_depth.width, h = v.real_depth.height;
  const size_t n = static_cast<size_t>(w) * static_cast<size_t>(h);
  if (v.rendered.width != w || v.rendered.height != h || v.rendered_depth_m.size() != n ||
      v.source.size() != n ||
      (!v.real_color.empty() && (v.real_color.width != w || v.real_color.height != h)))
    throw Error(fmt::format(
        "view quality: the rendered images ({}x{}, {} depths, {} sources) and the real ones "
        "({}x{} depth, {}x{} colour) differ in size",
        v.rendered.width, v.rendered.height, v.rendered_depth_m.size(), v.source.size(), w, h,
        v.real_color.width, v.real_color.height));
}

}  // namespace

ViewScore score_view(const ViewImages& v) {
  check_sizes(v);
  const int w = v.real_depth.width, h = v.real_depth.height;
  const bool colour = !v.real_color.empty();
  ViewScore s;
  std::vector<float> depth_error;
  double squared = 0;
  size_t colour_pixels = 0;
  ColorImage masked = v.rendered;  // compared pixels as drawn, the rest as the real image
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * static_cast<size_t>(w) + static_cast<size_t>(x);
      const uint16_t real = v.real_depth.pixels[i];
      const float drawn = v.rendered_depth_m[i];
      if (real) ++s.valid;
      const bool compared = real && drawn > 0;
      if (colour && !compared) std::copy_n(v.real_color.pixel(x, y), 4, masked.pixel(x, y));
      if (!compared) continue;
      ++s.compared;
      depth_error.push_back(std::abs(drawn * 1000.0f - static_cast<float>(real)));
      if (!colour) continue;
      const uint8_t* a = v.rendered.pixel(x, y);
      const uint8_t* b = v.real_color.pixel(x, y);
      for (int c = 0; c < 3; ++c) squared += double(a[c] - b[c]) * double(a[c] - b[c]);
      ++colour_pixels;
    }
  }
  s.coverage = s.valid ? double(s.compared) / double(s.valid) : 0;
  if (!depth_error.empty()) {
    double sum = 0;
    for (float e : depth_error) sum += e;
    s.depth_mean_mm = sum / double(depth_error.size());
    const auto p95 =
        depth_error.begin() + static_cast<std::ptrdiff_t>(0.95 * double(depth_error.size() - 1));
    std::nth_element(depth_error.begin(), p95, depth_error.end());
    s.depth_p95_mm = *p95;
  }
  if (colour_pixels) {
    const double mse = squared / (3.0 * double(colour_pixels));
    s.psnr_db = mse > 0 ? 10.0 * std::log10(255.0 * 255.0 / mse) : 99.0;
    const double frame = ssim_luma(masked, v.real_color);
    s.ssim = 1.0 - (1.0 - frame) * double(w) * double(h) / double(colour_pixels);
  }
  // Seams: where the dominant source camera changes between 4-neighbours that were both drawn.
  double energy = 0, error_energy = 0;
  size_t error_pixels = 0;
  const auto error_at = [&](int x, int y) {
    return luma(v.rendered.pixel(x, y)) - luma(v.real_color.pixel(x, y));
  };
  for (int y = 1; y + 1 < h; ++y) {
    for (int x = 1; x + 1 < w; ++x) {
      const size_t i = static_cast<size_t>(y) * static_cast<size_t>(w) + static_cast<size_t>(x);
      const uint8_t src = v.source[i];
      if (src == kNoSource) continue;
      const size_t around[4] = {i - 1, i + 1, i - static_cast<size_t>(w),
                                i + static_cast<size_t>(w)};
      bool seam = false;
      for (size_t j : around) seam |= v.source[j] != kNoSource && v.source[j] != src;
      if (!seam) continue;
      const float gx = 0.5f * (luma(v.rendered.pixel(x + 1, y)) - luma(v.rendered.pixel(x - 1, y)));
      const float gy = 0.5f * (luma(v.rendered.pixel(x, y + 1)) - luma(v.rendered.pixel(x, y - 1)));
      energy += double(gx * gx + gy * gy);
      ++s.seam_pixels;
      bool measured = colour && v.real_depth.pixels[i];
      for (size_t j : around) measured = measured && v.real_depth.pixels[j];
      if (!measured) continue;
      const float ex = 0.5f * (error_at(x + 1, y) - error_at(x - 1, y));
      const float ey = 0.5f * (error_at(x, y + 1) - error_at(x, y - 1));
      error_energy += double(ex * ex + ey * ey);
      ++error_pixels;
    }
  }
  s.seam_energy = s.seam_pixels ? energy / double(s.seam_pixels) : 0;
  s.seam_error_energy = error_pixels ? error_energy / double(error_pixels) : 0;
  return s;
}

ColorImage side_by_side(const ViewImages& v) {
  check_sizes(v);
  const int w = v.real_depth.width, h = v.real_depth.height;
  ColorImage out(4 * w, h);
  const auto put = [&](int panel, int x, int y, uint8_t b, uint8_t g, uint8_t r) {
    uint8_t* p = out.pixel(panel * w + x, y);
    p[0] = b, p[1] = g, p[2] = r, p[3] = 255;
  };
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * static_cast<size_t>(w) + static_cast<size_t>(x);
      const uint8_t* drawn = v.rendered.pixel(x, y);
      put(0, x, y, drawn[0], drawn[1], drawn[2]);
      const uint16_t real = v.real_depth.pixels[i];
      if (!v.real_color.empty()) {
        const uint8_t* c = v.real_color.pixel(x, y);
        const uint8_t dim = real ? 1 : 3;  // what the camera did not measure, darkened
        put(1, x, y, c[0] / dim, c[1] / dim, c[2] / dim);
      } else {
        const auto g = static_cast<uint8_t>(real ? std::clamp(255 - real / 20, 40, 255) : 0);
        put(1, x, y, g, g, g);
      }
      const bool is_drawn = v.rendered_depth_m[i] > 0;
      if (!real) {
        put(2, x, y, 16, 16, 16);
        put(3, x, y, 16, 16, 16);
        continue;
      }
      if (!is_drawn) {
        put(2, x, y, 255, 0, 255);
        put(3, x, y, 255, 0, 255);
        continue;
      }
      if (!v.real_color.empty()) {
        const uint8_t* c = v.real_color.pixel(x, y);
        const int e =
            std::abs(drawn[0] - c[0]) + std::abs(drawn[1] - c[1]) + std::abs(drawn[2] - c[2]);
        const auto g = static_cast<uint8_t>(std::min(255, e * 255 / 96));
        put(2, x, y, g, g, g);
      }
      const float e_mm = std::abs(v.rendered_depth_m[i] * 1000.0f - static_cast<float>(real));
      const float t = std::min(e_mm / 50.0f, 1.0f);  // green -> yellow -> red
      const auto red = static_cast<uint8_t>(255.0f * std::min(1.0f, 2.0f * t));
      const auto green = static_cast<uint8_t>(255.0f * std::min(1.0f, 2.0f - 2.0f * t));
      put(3, x, y, 0, green, red);
    }
  }
  return out;
}

}  // namespace volcast
