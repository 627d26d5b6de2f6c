#include "volcast/render/colour_balance.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <string>

#include "volcast/core/error.hpp"

namespace volcast {

int colour_sample_stride(int width, int height) {
  const double pixels = double(std::max(width, 1)) * double(std::max(height, 1));
  return std::max(2, static_cast<int>(std::ceil(std::sqrt(pixels / 6000.0))));
}

void take_colour_samples(const CameraFrame& frame, ColourSamples& s) {
  const Intrinsics& k = s.intrinsics;
  if (frame.depth.width != k.width || frame.depth.height != k.height)
    throw Error("colour balance: depth is " + std::to_string(frame.depth.width) + "x" +
                std::to_string(frame.depth.height) + ", the intrinsics " + std::to_string(k.width) +
                "x" + std::to_string(k.height));
  s.stride = colour_sample_stride(k.width, k.height);
  s.columns = (k.width + s.stride - 1) / s.stride;
  s.rows = (k.height + s.stride - 1) / s.stride;
  const size_t n = static_cast<size_t>(s.columns) * static_cast<size_t>(s.rows);
  s.depth_mm.assign(n, 0);
  s.rgb.assign(n, {0, 0, 0});
  if (frame.color.empty()) return;
  for (int r = 0; r < s.rows; ++r) {
    for (int c = 0; c < s.columns; ++c) {
      const int x = c * s.stride, y = r * s.stride;
      const size_t i =
          static_cast<size_t>(r) * static_cast<size_t>(s.columns) + static_cast<size_t>(c);
      s.depth_mm[i] = frame.depth.pixels[static_cast<size_t>(y) * static_cast<size_t>(k.width) +
                                         static_cast<size_t>(x)];
      const uint8_t* p = frame.color.pixel(x, y);
      s.rgb[i] = {p[2], p[1], p[0]};
    }
  }
}

std::vector<Eigen::Vector3f> colour_gains(std::span<const ColourSamples> cameras) {
  const size_t n = cameras.size();
  std::vector<Eigen::Vector3f> gains(n, Eigen::Vector3f::Ones());
  if (n < 2) return gains;
  // Per pair, the summed colours of samples both see.
  struct Pair {
    size_t i, j;
    double count = 0;
    Eigen::Vector3d sum_i = Eigen::Vector3d::Zero(), sum_j = Eigen::Vector3d::Zero();
  };
  std::vector<Pair> pairs;
  for (size_t i = 0; i < n; ++i) {
    const ColourSamples& a = cameras[i];
    if (!a.rays || a.depth_mm.empty()) continue;
    for (size_t j = 0; j < n; ++j) {
      const ColourSamples& b = cameras[j];
      if (j == i || !b.rays || b.depth_mm.empty()) continue;
      Pair pair{i, j};
      const RigidTransform b_from_a = b.world_from_camera.inverse() * a.world_from_camera;
      for (int r = 0; r < a.rows; ++r) {
        for (int c = 0; c < a.columns; ++c) {
          const size_t si =
              static_cast<size_t>(r) * static_cast<size_t>(a.columns) + static_cast<size_t>(c);
          const uint16_t d = a.depth_mm[si];
          if (!d) continue;
          const size_t pixel =
              static_cast<size_t>(r * a.stride) * static_cast<size_t>(a.intrinsics.width) +
              static_cast<size_t>(c * a.stride);
          const float rx = a.rays->x[pixel], ry = a.rays->y[pixel];
          if (std::isnan(rx)) continue;
          const double z = d * 0.001;
          const Eigen::Vector3d q = b_from_a * Eigen::Vector3d(rx * z, ry * z, z);
          if (q.z() <= 0.1) continue;
          const auto uv = project_normalized(b.intrinsics, {q.x() / q.z(), q.y() / q.z()});
          if (!uv) continue;
          const long bc = std::lround(uv->x() / b.stride), br = std::lround(uv->y() / b.stride);
          if (bc < 0 || br < 0 || bc >= b.columns || br >= b.rows) continue;
          const size_t sj =
              static_cast<size_t>(br) * static_cast<size_t>(b.columns) + static_cast<size_t>(bc);
          const uint16_t dj = b.depth_mm[sj];
          if (!dj || std::abs(dj * 0.001 - q.z()) > 0.02 + 0.02 * q.z()) continue;
          pair.count += 1;
          for (int ch = 0; ch < 3; ++ch) {
            pair.sum_i[ch] += a.rgb[si][static_cast<size_t>(ch)];
            pair.sum_j[ch] += b.rgb[sj][static_cast<size_t>(ch)];
          }
        }
      }
      if (pair.count >= 64) pairs.push_back(pair);
    }
  }
  if (pairs.empty()) return gains;
  const auto nn = static_cast<Eigen::Index>(n);
  for (int ch = 0; ch < 3; ++ch) {
    Eigen::MatrixXd a = 0.01 * Eigen::MatrixXd::Identity(nn, nn);
    Eigen::VectorXd b = Eigen::VectorXd::Zero(nn);
    for (const Pair& p : pairs) {
      const double si = std::max(p.sum_i[ch], 1.0), sj = std::max(p.sum_j[ch], 1.0);
      const double r = std::log(si / sj);  // g_i - g_j should be -r
      const auto i = static_cast<Eigen::Index>(p.i), j = static_cast<Eigen::Index>(p.j);
      a(i, i) += p.count, a(j, j) += p.count, a(i, j) -= p.count, a(j, i) -= p.count;
      b(i) -= p.count * r, b(j) += p.count * r;
    }
    const Eigen::VectorXd g = a.ldlt().solve(b);
    for (size_t k = 0; k < n; ++k)
      gains[k][ch] =
          static_cast<float>(std::clamp(std::exp(g(static_cast<Eigen::Index>(k))), 0.5, 2.0));
  }
  return gains;
}

}  // namespace volcast
