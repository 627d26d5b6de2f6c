#pragma once
// Colour balance between cameras: a gain per camera and channel so that cameras agree on the
// colour of the surfaces they both see (auto exposure and white balance differ between Azure
// Kinects). Not per frame: CameraRenderer re-estimates every 15 new images from a fixed grid of
// samples per camera, so the cost does not grow with the number of points.
//
// Method (ours; the least-squares gain compensation of panorama stitching, Brown & Lowe 2007
// §6, on colour means): every sample of camera i (depth, colour) is placed in the world and
// projected into camera j (its lens model included); where j's nearest sample agrees in depth
// (within 2 cm + 2 % of the depth), both colours are summed. For each pair with at least 64 such
// samples, log(mean_i / mean_j) per channel is a measured difference of gains; the log gains
// g minimise sum over pairs n_ij (g_i - g_j + log(mean_i / mean_j))^2 + 0.01 sum g_i^2 (so a
// camera that overlaps nobody keeps gain 1), and each gain is clamped to 0.5..2.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "volcast/core/calibration.hpp"
#include "volcast/core/frame.hpp"
#include "volcast/core/ray_table.hpp"

namespace volcast {

/// One camera's samples: every stride-th pixel in x and y.
struct ColourSamples {
  Intrinsics intrinsics;
  RigidTransform world_from_camera;
  std::shared_ptr<const RayTable> rays;  ///< of `intrinsics`
  int stride = 8;                        ///< pixels between samples
  int columns = 0, rows = 0;             ///< the grid: ceil(width / stride) x ceil(height / stride)
  std::vector<uint16_t> depth_mm;        ///< columns x rows, 0 = invalid
  std::vector<std::array<uint8_t, 3>> rgb;  ///< columns x rows
};

/// The stride that keeps a width x height image to about 6000 samples (at least 2).
int colour_sample_stride(int width, int height);

/// Fills `s` from `frame` (depth mm, colour BGRA registered to it; empty colour: no samples are
/// kept). Reuses its buffers. Throws Error if the frame's size differs from the intrinsics.
void take_colour_samples(const CameraFrame& frame, ColourSamples& s);

/// The gains (RGB, multiply the colour) of each camera of `cameras` (see the top of this file).
std::vector<Eigen::Vector3f> colour_gains(std::span<const ColourSamples> cameras);

}  // namespace volcast
