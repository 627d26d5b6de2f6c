#pragma once
// Test helpers: the shared real speech (48 kHz mono WAVs) read with libsndfile, and the measures
// the audio tests quote (energy in dB, normalised cross-correlation over a range of lags).
#include <sndfile.h>

#include <algorithm>
#include <cmath>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "support/test_paths.hpp"

namespace volcast::audio::test {

/// The speech file `name` from ../shared/data/speech as float mono samples at 48 kHz.
inline std::vector<float> read_speech(const std::string& name) {
  const std::string path = std::string(volcast::test::paths::data()) + "/speech/" + name;
  SF_INFO info{};
  SNDFILE* file = sf_open(path.c_str(), SFM_READ, &info);
  if (file == nullptr)
    throw std::runtime_error("cannot open " + path + ": " + sf_strerror(nullptr));
  if (info.channels != 1 || info.samplerate != 48000) {
    sf_close(file);
    throw std::runtime_error(path + " is not 48 kHz mono");
  }
  std::vector<float> samples(static_cast<size_t>(info.frames));
  const sf_count_t got = sf_readf_float(file, samples.data(), info.frames);
  sf_close(file);
  samples.resize(static_cast<size_t>(std::max<sf_count_t>(got, 0)));
  return samples;
}

inline double energy(std::span<const float> x) {
  double sum = 0;
  for (const float v : x) sum += static_cast<double>(v) * v;
  return sum;
}

inline double db(double ratio) {
  return 10.0 * std::log10(ratio);
}

/// Normalised correlation of a[n] with b[n - lag] over their overlap.
inline double correlation_at(std::span<const float> a, std::span<const float> b, long lag) {
  double ab = 0, aa = 0, bb = 0;
  const long n = static_cast<long>(std::min(a.size(), b.size()));
  for (long i = std::max(0L, lag); i < n && i - lag < n; ++i) {
    const double x = a[static_cast<size_t>(i)];
    const double y = b[static_cast<size_t>(i - lag)];
    ab += x * y;
    aa += x * x;
    bb += y * y;
  }
  return aa > 0 && bb > 0 ? ab / std::sqrt(aa * bb) : 0.0;
}

/// x high-passed at 200 Hz (second-order Butterworth, RBJ cookbook biquad) forward then backward
/// (zero phase): the speech band, for comparing signals one of which went through webrtc's own
/// high-pass filter (which removes the recordings' rumble below ~100 Hz).
inline std::vector<float> speech_band(std::span<const float> x) {
  const double w = 2.0 * 3.14159265358979323846 * 200.0 / 48000.0;
  const double alpha = std::sin(w) / (2.0 * std::sqrt(0.5));
  const double a0 = 1 + alpha;
  const double b0 = (1 + std::cos(w)) / 2 / a0, b1 = -(1 + std::cos(w)) / a0, b2 = b0;
  const double a1 = -2 * std::cos(w) / a0, a2 = (1 - alpha) / a0;
  std::vector<double> y(x.begin(), x.end());
  for (int pass = 0; pass < 2; ++pass) {
    double x1 = 0, x2 = 0, y1 = 0, y2 = 0;
    for (double& v : y) {
      const double out = b0 * v + b1 * x1 + b2 * x2 - a1 * y1 - a2 * y2;
      x2 = x1;
      x1 = v;
      y2 = y1;
      y1 = out;
      v = out;
    }
    std::reverse(y.begin(), y.end());
  }
  return std::vector<float>(y.begin(), y.end());
}

struct Peak {
  double correlation = 0;
  long lag = 0;  ///< samples by which `a` lags `b`
};

/// The largest normalised correlation of a[n] with b[n - lag] for lag in [min_lag, max_lag].
inline Peak best_correlation(std::span<const float> a, std::span<const float> b, long min_lag,
                             long max_lag) {
  Peak best{-2.0, 0};
  for (long lag = min_lag; lag <= max_lag; ++lag) {
    const double c = correlation_at(a, b, lag);
    if (c > best.correlation) best = {c, lag};
  }
  return best;
}

}  // namespace volcast::audio::test
