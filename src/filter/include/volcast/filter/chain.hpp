#pragma once
// The per-camera filter chain the server runs before encoding, and its configuration.
// Order: lens correction + crop (one gather) -> near/far threshold -> learned background ->
// flying-pixel removal -> hole filling -> Kalman denoising. Color follows the gather map.
#include <array>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>

#include "volcast/core/frame.hpp"
#include "volcast/filter/filters.hpp"

namespace volcast {

struct FilterConfig {
  bool undistort = false;
  std::optional<CropRect> crop;           ///< nullopt: no crop
  uint16_t near_mm = 0, far_mm = 0;       ///< 0 = no bound
  std::filesystem::path background_file;  ///< learned background (16-bit PNG), empty = none
  uint16_t background_margin_mm = 30;
  std::optional<FlyingPixelFilter> flying_pixels;
  std::optional<HoleFiller> hole_filling;
  std::optional<KalmanFilter> kalman;

  bool any() const {
    return undistort || crop || near_mm || far_mm || !background_file.empty() || flying_pixels ||
           hole_filling || kalman;
  }
};

/// Applies a JSON object's fields to `config` (fields not present keep their value):
///   "undistort": bool, "crop": "nfov" | [x, y, w, h] | false, "near_mm", "far_mm",
///   "background": "file.png", "background_margin_mm",
///   "flying_pixels": bool | {"abs_mm", "rel", "min_support"},
///   "hole_fill": iterations | false | {"iterations", "min_neighbours", "max_spread_mm"},
///   "kalman": bool | {"noise_mm_at_1m", "process_mm", "gate_sigmas", "gate_min_mm",
///   "gate_max_mm"}.
/// `json_text` is the object's text. Throws Error naming the bad field.
void apply_filter_json(const std::string& json_text, FilterConfig& config);

/// The chain the paper times (and Volcast's performance goal names): lens correction, crop (the
/// NFOV box on 640x576 images, none otherwise), near/far threshold 200..5000 mm, 3 hole-filling
/// iterations and Kalman denoising, all with default parameters.
FilterConfig paper_chain_config(int width, int height);

/// Parses a crop flag: "nfov" (the paper's 540x476 box for 640x576 Azure Kinect NFOV) or
/// "x,y,w,h". Throws Error otherwise.
CropRect parse_crop(const std::string& text);

/// Time each stage took on the last frame, microseconds (0 for a stage that is off).
struct FilterTimings {
  static constexpr int kStages = 6;
  static constexpr std::array<const char*, kStages> kNames = {
      "lens_correction_crop", "threshold", "background", "flying_pixels", "hole_filling", "kalman"};
  std::array<double, kStages> us{};
  double total_us() const {
    double t = 0;
    for (double v : us) t += v;
    return t;
  }
};

class FilterChain {
 public:
  /// Builds the gather map and loads the background model. Throws Error if the crop does not fit,
  /// the background file is missing or differs in size from the filtered image.
  FilterChain(const Intrinsics& source, FilterConfig config);
  /// Intrinsics of the filtered images (what the server announces).
  const Intrinsics& output_intrinsics() const { return map_.output; }
  /// Called after each enabled stage with its index (FilterTimings::kNames) and the depth so far.
  using StageObserver = std::function<void(int stage, const DepthImage& depth)>;
  /// Filters one camera frame; `out` buffers are reused. Timestamps are copied. `observer`, if
  /// set, sees every intermediate result (for quality measurements; timings then include it).
  void apply(const CameraFrame& in, CameraFrame& out, const StageObserver& observer = {});
  const FilterTimings& last_timings() const { return timings_; }
  const FilterConfig& config() const { return config_; }

 private:
  FilterConfig config_;
  PixelMap map_;
  std::optional<BackgroundModel> background_;
  FilterTimings timings_;
};

}  // namespace volcast
