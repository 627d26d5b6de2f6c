#pragma once
// Per-camera depth preprocessing, run on the capture server before compression (Fischer et al.,
// Sec. 3: lens correction, cropping, background subtraction, hole filling, Kalman denoising; plus
// flying-pixel removal). Each filter is a free function or a small stateful struct working on
// uint16 millimetre depth (0 = invalid); none allocates per frame once its buffers have grown.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <vector>

#include "volcast/core/calibration.hpp"
#include "volcast/core/image.hpp"

namespace volcast {

/// A rectangle of pixels: columns x..x+width-1, rows y..y+height-1.
struct CropRect {
  int x = 0, y = 0, width = 0, height = 0;
  bool operator==(const CropRect&) const = default;
};

/// The paper's cropped mode for Azure Kinect NFOV unbinned (640x576): the centred 540x476 box
/// around the valid region.
inline constexpr CropRect kNfovCrop{50, 50, 540, 476};

/// Lens correction and cropping as one precomputed per-pixel gather map: output pixel i takes
/// source pixel map[i] (nearest neighbour, so depth is never interpolated across an edge), or 0
/// where its ray falls outside the source image.
struct PixelMap {
  Intrinsics output;         ///< intrinsics of the output image (pinhole if undistorted)
  std::vector<int32_t> map;  ///< output.width*output.height source indices, -1 = none
};

/// Builds the map. `undistort`: the output is an ideal pinhole with the source's fx, fy, cx, cy
/// (then shifted by the crop), else the source model is kept. `crop` is in output pixel
/// coordinates of the full-size image; it must lie inside the source size.
/// Throws Error for an empty or out-of-bounds crop.
PixelMap make_pixel_map(const Intrinsics& source, bool undistort, std::optional<CropRect> crop);

/// out[i] = in[map[i]] (0 where map is -1). `out` is resized to the map's size and reused.
void apply_pixel_map(const PixelMap& map, const DepthImage& in, DepthImage& out);
/// The same gather for BGRA color registered to the depth image.
void apply_pixel_map(const PixelMap& map, const ColorImage& in, ColorImage& out);

/// Drops depth outside [near_mm, far_mm] (set to 0). A bound of 0 means "no bound".
void threshold_depth(DepthImage& depth, uint16_t near_mm, uint16_t far_mm);

/// Learned background: the per-pixel minimum valid depth over frames of the empty room.
struct BackgroundModel {
  DepthImage min_depth;  ///< 0 where no frame had a valid measurement

  /// Folds one empty-room frame into the model (same size as earlier frames).
  void learn(const DepthImage& frame);
  /// Drops (sets to 0) every pixel that is not nearer than the background by more than
  /// `margin_mm`; pixels with no background measurement are kept. Throws Error on a size mismatch.
  void subtract(DepthImage& depth, uint16_t margin_mm) const;
  /// Saved as a 16-bit PNG (millimetres), one file per camera, viewable in any image viewer.
  void save(const std::filesystem::path& file) const;
  static BackgroundModel load(const std::filesystem::path& file);
};

/// Removes flying pixels: a valid pixel is dropped when fewer than `min_support` of its 8
/// neighbours are valid and within max(abs_mm, rel * depth) of it (mixed foreground/background
/// returns at depth discontinuities have few such neighbours).
struct FlyingPixelFilter {
  uint16_t abs_mm = 25;
  float rel = 0.03f;
  int min_support = 3;
  void apply(DepthImage& depth);

 private:
  DepthImage scratch_;
};

/// Hole filling by iterated median (the paper's "several iterations"): an invalid pixel with at
/// least `min_neighbours` valid 8-neighbours takes their median, unless their depth spread
/// (max - min) exceeds `max_spread_mm`, so a hole on a step edge is never bridged. Each iteration
/// reads the previous one's result. Filled values always lie within their neighbours' range.
struct HoleFiller {
  int iterations = 3;
  int min_neighbours = 4;
  uint16_t max_spread_mm = 40;
  void apply(DepthImage& depth);

 private:
  std::vector<uint32_t> candidates_;
  std::vector<uint16_t> fill_values_;
  std::vector<uint32_t> fill_index_;
  std::vector<uint8_t> queued_;
};

/// Per-pixel Kalman filter on depth with a constant-depth model. Measurement noise grows with
/// depth, sigma_mm = noise_mm_at_1m * z_m^2 (time-of-flight noise model); process noise
/// `process_mm` per frame. An innovation larger than `gate_sigmas` standard deviations, clamped to
/// [gate_min_mm, gate_max_mm], means the surface really moved: the pixel takes the new value at
/// once (no ghosting; a change over gate_max_mm is always motion, however noisy the depth). A
/// pixel turning invalid outputs 0 and resets; turning valid starts from the new value.
struct KalmanFilter {
  float noise_mm_at_1m = 1.5f;
  float process_mm = 0.7f;
  float gate_sigmas = 3.0f;
  float gate_min_mm = 8.0f;
  float gate_max_mm = 20.0f;
  void apply(DepthImage& depth);
  void reset() { estimate_.clear(); }

 private:
  std::vector<float> estimate_, variance_;
};

}  // namespace volcast
