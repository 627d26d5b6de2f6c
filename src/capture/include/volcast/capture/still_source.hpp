#pragma once
// A still camera: one depth PNG (16-bit, millimetres, 0 = invalid) repeated at a fixed rate, with
// an optional color image. For sets that hold one capture per camera, such as the four Azure
// Kinects of k4a-4cam-nfov.
#include <filesystem>
#include <memory>

#include "volcast/capture/source.hpp"

namespace volcast {

/// Opens a still camera. `calibration.depth` gives the intrinsics (its width and height are set
/// from the PNG). A color image of another size is resampled to the depth grid by nearest
/// neighbour: NOT registered (the set has no extrinsics), so colors sit only roughly on the
/// surfaces -- fine for streaming and codec cost, not for looking closely. Device timestamps
/// advance by 1/fps per frame. Throws Error if a file cannot be read.
std::unique_ptr<FrameSource> open_still_source(const std::filesystem::path& depth_png,
                                               const std::filesystem::path& color_image,
                                               CameraCalibration calibration, double fps);

}  // namespace volcast
