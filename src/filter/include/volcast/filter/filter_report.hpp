#pragma once
// How much a FilterChain does to a recording (`volcast filter`): the share of invalid pixels
// before and after hole filling, the temporal noise of static pixels before and after the Kalman
// filter, and how far the output lags a pixel that truly moved; and the before/after picture a
// person looks at. Depth in millimetres; the figures are measured on the frames given (real ones:
// a recording), none is assumed.
#include <cstddef>
#include <functional>
#include <string>

#include "volcast/core/frame.hpp"
#include "volcast/core/image.hpp"
#include "volcast/filter/chain.hpp"

namespace volcast {

struct FilterReport {
  int frames = 0;
  int width = 0, height = 0;  ///< the chain's output, after lens correction and crop
  bool hole_filling = false, kalman = false;
  double invalid_before_fill = 0;  ///< mean share (0..1) of invalid pixels entering hole filling
  double invalid_after_fill = 0;   ///< and leaving it
  /// Pixels valid in every frame whose input never spans more than 50 mm: their mean temporal
  /// standard deviation (mm) entering and leaving the Kalman filter (0 with fewer than 2 frames).
  size_t static_pixels = 0;
  double noise_before_mm = 0, noise_after_mm = 0;
  /// Samples of a pixel whose input moved more than 20 mm since the last frame: |output - input|
  /// (mm), its mean, 99th percentile and largest.
  size_t moving_samples = 0;
  double moving_mean_mm = 0, moving_p99_mm = 0, moving_max_mm = 0;
};

/// Runs `frames` frames (>= 1) from `next` (fills its argument with the next camera frame;
/// throws what it throws) through `chain`, measuring as FilterReport says. `snapshot(f, raw,
/// filtered)`, if given, sees frames 0, frames / 2 and frames - 1.
FilterReport measure_filter(
    FilterChain& chain, const FilterConfig& config, const std::function<void(CameraFrame&)>& next,
    int frames,
    const std::function<void(int, const CameraFrame&, const CameraFrame&)>& snapshot = {});

/// `before` and `after` side by side in false colour for a person to look at: a "jet" ramp from
/// red (near) to blue (far) over the 2nd..98th percentile of `before`'s valid depth; invalid
/// black.
ColorImage before_after_picture(const DepthImage& before, const DepthImage& after);

/// The report as the JSON object `volcast filter` writes to quality.json (2-space indent).
std::string to_json(const FilterReport& r, const std::string& source);

}  // namespace volcast
