#pragma once
// PNG reading and writing (libpng) for depth (16-bit grayscale, millimetres) and color images.
#include <filesystem>

#include "volcast/core/image.hpp"

namespace volcast {

/// Reads a 16-bit single-channel PNG as depth in millimetres. Throws Error naming the file if it
/// is missing, not a PNG, truncated, or not 16-bit grayscale.
DepthImage read_depth_png(const std::filesystem::path& path);

/// Writes depth as a 16-bit grayscale PNG (values unchanged, millimetres). Throws Error on failure.
void write_depth_png(const std::filesystem::path& path, const DepthImage& depth);

/// Reads an 8-bit gray, RGB or RGBA PNG as BGRA (A = 255 where the file has no alpha).
ColorImage read_color_png(const std::filesystem::path& path);

/// Writes BGRA as an 8-bit RGBA PNG (alpha kept). Throws Error on failure.
void write_color_png(const std::filesystem::path& path, const ColorImage& color);

}  // namespace volcast
