#pragma once
// PNG reading and writing (libpng) for depth (16-bit grayscale, millimetres) and color images.
#include <filesystem>

#include "volcast/core/image.hpp"

namespace volcast {

// Reading refuses, with an Error naming the file: a missing file, one that is not a PNG, a header
// claiming more than kMaxImageSide (image.hpp) pixels per side ("PNG 'f' claims WxH pixels, ...",
// before any pixel memory is allocated), data that ends early ("truncated PNG 'f': ...") and any
// other error libpng reports ("corrupt PNG 'f': ...", e.g. a bad CRC).

/// Reads a 16-bit single-channel PNG as depth in millimetres. Throws Error naming the file as
/// above, or if it is not 16-bit grayscale.
DepthImage read_depth_png(const std::filesystem::path& path);

/// Writes depth as a 16-bit grayscale PNG (values unchanged, millimetres). Throws Error on failure.
void write_depth_png(const std::filesystem::path& path, const DepthImage& depth);

/// Reads an 8-bit gray, RGB or RGBA PNG as BGRA (A = 255 where the file has no alpha). Throws
/// Error naming the file as above.
ColorImage read_color_png(const std::filesystem::path& path);

/// Writes BGRA as an 8-bit RGBA PNG (alpha kept). Throws Error on failure.
void write_color_png(const std::filesystem::path& path, const ColorImage& color);

}  // namespace volcast
