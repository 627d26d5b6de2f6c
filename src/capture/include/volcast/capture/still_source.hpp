#pragma once
// A still camera: one depth PNG (16-bit, millimetres, 0 = invalid) repeated at a fixed rate, with
// an optional color image. For sets that hold one capture per camera, such as the four Azure
// Kinects of k4a-4cam-nfov.
#include <filesystem>
#include <memory>

#include "volcast/capture/source.hpp"

namespace volcast {

/// `in` resampled to width x height by nearest neighbour (pixel centres scaled, not registered).
ColorImage resample_nearest(const ColorImage& in, int width, int height);

/// Reads a color image as BGRA: a PNG, or a JPEG (.jpg/.jpeg, by extension, any case). Throws
/// Error naming the file when it cannot be read or decoded.
ColorImage read_color_image(const std::filesystem::path& file);

/// Opens a still camera. `calibration.depth` gives the intrinsics (its width and height are set
/// from the PNG). `color_image` (PNG or JPEG; empty = no color) of another size is resampled to the
/// depth grid by nearest neighbour: NOT registered (the set has no extrinsics), so colors sit only
/// roughly on the surfaces -- fine for streaming and codec cost, not for looking closely. Device
/// timestamps advance by 1/fps per frame. With `nominal_color` and a color image of its size, the
/// color is registered to depth with it instead (pixels without depth, or seeing outside the
/// color image, get no color). Throws Error if a file cannot be read.
std::unique_ptr<FrameSource> open_still_source(
    const std::filesystem::path& depth_png, const std::filesystem::path& color_image,
    CameraCalibration calibration, double fps,
    const std::optional<ColorCalibration>& nominal_color = std::nullopt);

}  // namespace volcast
