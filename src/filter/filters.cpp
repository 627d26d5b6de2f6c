#include "volcast/filter/filters.hpp"

#include <algorithm>
#include <cmath>

#include "volcast/core/error.hpp"
#include "volcast/core/image_io.hpp"

namespace volcast {

PixelMap make_pixel_map(const Intrinsics& source, bool undistort, std::optional<CropRect> crop) {
  const CropRect r = crop.value_or(CropRect{0, 0, source.width, source.height});
  if (r.width <= 0 || r.height <= 0 || r.x < 0 || r.y < 0 || r.x + r.width > source.width ||
      r.y + r.height > source.height)
    throw Error("crop " + std::to_string(r.x) + "," + std::to_string(r.y) + "," +
                std::to_string(r.width) + "," + std::to_string(r.height) + " does not fit the " +
                std::to_string(source.width) + "x" + std::to_string(source.height) + " image");
  PixelMap m;
  m.output = source;
  if (undistort) {
    m.output = Intrinsics{};
    m.output.fx = source.fx, m.output.fy = source.fy, m.output.cx = source.cx,
    m.output.cy = source.cy;
  }
  m.output.width = r.width;
  m.output.height = r.height;
  m.output.cx -= r.x;
  m.output.cy -= r.y;
  m.map.assign(static_cast<size_t>(r.width) * r.height, -1);
  for (int v = 0; v < r.height; ++v) {
    for (int u = 0; u < r.width; ++u) {
      const int su0 = u + r.x, sv0 = v + r.y;
      int su = su0, sv = sv0;
      if (undistort) {
        const Eigen::Vector2d xy((su0 - source.cx) / source.fx, (sv0 - source.cy) / source.fy);
        const auto uv = project_normalized(source, xy);
        if (!uv) continue;
        su = static_cast<int>(std::lround(uv->x()));
        sv = static_cast<int>(std::lround(uv->y()));
        if (su < 0 || sv < 0 || su >= source.width || sv >= source.height) continue;
      }
      m.map[static_cast<size_t>(v) * r.width + u] = sv * source.width + su;
    }
  }
  return m;
}

void apply_pixel_map(const PixelMap& m, const DepthImage& in, DepthImage& out) {
  if (out.width != m.output.width || out.height != m.output.height)
    out = DepthImage(m.output.width, m.output.height);
  const uint16_t* src = in.pixels.data();
  uint16_t* dst = out.pixels.data();
  for (size_t i = 0; i < m.map.size(); ++i) {
    const int32_t s = m.map[i];
    dst[i] = s >= 0 ? src[s] : uint16_t{0};
  }
}

void apply_pixel_map(const PixelMap& m, const ColorImage& in, ColorImage& out) {
  if (in.empty()) {
    out = ColorImage();
    return;
  }
  if (out.width != m.output.width || out.height != m.output.height)
    out = ColorImage(m.output.width, m.output.height);
  const uint32_t* src = reinterpret_cast<const uint32_t*>(in.bgra.data());
  uint32_t* dst = reinterpret_cast<uint32_t*>(out.bgra.data());
  for (size_t i = 0; i < m.map.size(); ++i) {
    const int32_t s = m.map[i];
    dst[i] = s >= 0 ? src[s] : 0u;
  }
}

void threshold_depth(DepthImage& depth, uint16_t near_mm, uint16_t far_mm) {
  const uint16_t hi = far_mm ? far_mm : uint16_t{65535};
  for (uint16_t& d : depth.pixels) d = (d >= near_mm && d <= hi) ? d : uint16_t{0};
}

void BackgroundModel::learn(const DepthImage& frame) {
  if (min_depth.width == 0) {
    min_depth = frame;
    return;
  }
  if (frame.width != min_depth.width || frame.height != min_depth.height)
    throw Error("background: frame size differs from the frames learned so far");
  for (size_t i = 0; i < frame.size(); ++i) {
    const uint16_t d = frame.pixels[i], m = min_depth.pixels[i];
    min_depth.pixels[i] = d == 0 ? m : (m == 0 ? d : std::min(d, m));
  }
}

void BackgroundModel::subtract(DepthImage& depth, uint16_t margin_mm) const {
  if (depth.width != min_depth.width || depth.height != min_depth.height)
    throw Error("background model is " + std::to_string(min_depth.width) + "x" +
                std::to_string(min_depth.height) + " but the frame is " +
                std::to_string(depth.width) + "x" + std::to_string(depth.height));
  for (size_t i = 0; i < depth.size(); ++i) {
    const int bg = min_depth.pixels[i];
    const int d = depth.pixels[i];
    depth.pixels[i] = (bg == 0 || d + margin_mm < bg) ? depth.pixels[i] : uint16_t{0};
  }
}

void BackgroundModel::save(const std::filesystem::path& file) const {
  if (min_depth.width == 0) throw Error("background model is empty: learn at least one frame");
  write_depth_png(file, min_depth);
}

BackgroundModel BackgroundModel::load(const std::filesystem::path& file) {
  BackgroundModel m;
  m.min_depth = read_depth_png(file);
  return m;
}

void FlyingPixelFilter::apply(DepthImage& depth) {
  scratch_.width = depth.width;
  scratch_.height = depth.height;
  scratch_.pixels.assign(depth.pixels.begin(), depth.pixels.end());
  const int w = depth.width;
  const uint16_t* in = scratch_.pixels.data();
  for (int y = 1; y + 1 < depth.height; ++y) {
    for (int x = 1; x + 1 < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      const int d = in[i];
      if (d == 0) continue;
      const int thr = std::max<int>(abs_mm, static_cast<int>(rel * static_cast<float>(d)));
      int support = 0;
      for (const ptrdiff_t off : {-w - 1, -w, -w + 1, -1, 1, w - 1, w, w + 1}) {
        const int n = in[static_cast<ptrdiff_t>(i) + off];
        support += n != 0 && std::abs(n - d) <= thr;
      }
      if (support < min_support) depth.pixels[i] = 0;
    }
  }
}

namespace {

// Sorts up to 8 values in place (insertion sort: fastest for so few).
inline void sort_small(uint16_t* v, int n) {
  for (int i = 1; i < n; ++i) {
    const uint16_t x = v[i];
    int j = i - 1;
    while (j >= 0 && v[j] > x) {
      v[j + 1] = v[j];
      --j;
    }
    v[j + 1] = x;
  }
}

}  // namespace

void HoleFiller::apply(DepthImage& depth) {
  static constexpr int kDx[8] = {-1, 0, 1, -1, 1, -1, 0, 1};
  static constexpr int kDy[8] = {-1, -1, -1, 0, 0, 1, 1, 1};
  const int w = depth.width, h = depth.height;
  if (w < 3 || h < 3 || iterations <= 0) return;
  if (iterations > 250) throw Error("hole filling: at most 250 iterations");
  uint16_t* px = depth.pixels.data();
  const ptrdiff_t offsets[8] = {-w - 1, -w, -w + 1, -1, 1, w - 1, w, w + 1};
  // Queues pixel i's fill if enough valid neighbours agree (all reads see the previous iteration).
  auto try_fill = [&](uint32_t i) {
    uint16_t v[8];
    int n = 0;
    for (const ptrdiff_t off : offsets) {
      const uint16_t d = px[static_cast<ptrdiff_t>(i) + off];
      v[n] = d;
      n += d != 0;
    }
    if (n < min_neighbours) return;
    sort_small(v, n);
    if (v[n - 1] - v[0] > max_spread_mm) return;  // would bridge foreground and background
    fill_index_.push_back(i);
    fill_values_.push_back(v[(n - 1) / 2]);
  };
  if (fill_index_.capacity() < depth.size()) {  // worst case once, so no frame ever allocates
    fill_index_.reserve(depth.size());
    fill_values_.reserve(depth.size());
    candidates_.reserve(depth.size());
  }
  fill_index_.clear();
  fill_values_.clear();
  for (int y = 1; y + 1 < h; ++y) {
    const uint32_t row = static_cast<uint32_t>(y * w);
    for (int x = 1; x + 1 < w; ++x)
      if (px[row + x] == 0) try_fill(row + static_cast<uint32_t>(x));
  }
  if (queued_.size() != depth.size()) queued_.assign(depth.size(), 0);
  for (int iter = 1; iter <= iterations && !fill_index_.empty(); ++iter) {
    for (size_t k = 0; k < fill_index_.size(); ++k) px[fill_index_[k]] = fill_values_[k];
    if (iter == iterations) break;
    // Only still-invalid neighbours of newly filled pixels can become fillable.
    candidates_.clear();
    for (const uint32_t i : fill_index_) {
      const int x = static_cast<int>(i % static_cast<uint32_t>(w)),
                y = static_cast<int>(i / static_cast<uint32_t>(w));
      for (int k = 0; k < 8; ++k) {
        const int jx = x + kDx[k], jy = y + kDy[k];
        if (jx < 1 || jx + 1 >= w || jy < 1 || jy + 1 >= h) continue;
        const uint32_t j = static_cast<uint32_t>(jy * w + jx);
        if (px[j] != 0 || queued_[j]) continue;
        queued_[j] = 1;
        candidates_.push_back(j);
      }
    }
    for (const uint32_t j : candidates_) queued_[j] = 0;  // leave the marks clear for the next use
    fill_index_.clear();
    fill_values_.clear();
    for (const uint32_t j : candidates_) try_fill(j);
  }
}

void KalmanFilter::apply(DepthImage& depth) {
  const size_t n = depth.size();
  if (estimate_.size() != n) {
    estimate_.assign(n, 0.0f);
    variance_.assign(n, 0.0f);
  }
  float* x = estimate_.data();
  float* p = variance_.data();
  uint16_t* z = depth.pixels.data();
  const float q = process_mm * process_mm;
  const float noise2 = noise_mm_at_1m * noise_mm_at_1m;
  const float gate2_sigmas = gate_sigmas * gate_sigmas;
  const float gate2_min = gate_min_mm * gate_min_mm;
  const float gate2_max = std::max(gate_max_mm, gate_min_mm) * std::max(gate_max_mm, gate_min_mm);
  // Branch-free so the compiler vectorises it.
  for (size_t i = 0; i < n; ++i) {
    const float zi = z[i];
    const float zm = zi * 0.001f;
    const float r = noise2 * (zm * zm) * (zm * zm);  // sigma = noise_at_1m * z^2
    const float p_pred = p[i] + q;
    const float innovation = zi - x[i];
    const float s = p_pred + r;
    const float k = p_pred / s;
    const float gate2_noise = gate2_sigmas * s;
    const float gate2_low = gate2_noise > gate2_min ? gate2_noise : gate2_min;
    const float gate2 = gate2_low < gate2_max ? gate2_low : gate2_max;
    const bool fresh = (x[i] == 0.0f) | (innovation * innovation > gate2);
    const bool valid = zi != 0.0f;
    const float smoothed_x = x[i] + k * innovation;
    const float smoothed_p = (1.0f - k) * p_pred;
    const float x_new = fresh ? zi : smoothed_x;
    const float p_new = fresh ? r : smoothed_p;
    const float x_out = valid ? x_new : 0.0f;
    x[i] = x_out;
    p[i] = valid ? p_new : 0.0f;
    z[i] = static_cast<uint16_t>(static_cast<int32_t>(x_out + 0.5f));
  }
}

}  // namespace volcast
