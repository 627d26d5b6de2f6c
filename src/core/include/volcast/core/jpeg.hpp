#pragma once
// JPEG through libjpeg-turbo's TurboJPEG API, BGRA in memory.
#include <cstdint>
#include <span>
#include <vector>

#include "volcast/core/image.hpp"

namespace volcast {

/// Decodes a baseline/progressive JPEG (any subsampling) to BGRA with A = 255. `out` is resized
/// and reused. Throws Error("corrupt JPEG: ...") on malformed or truncated data.
void decode_jpeg(std::span<const uint8_t> jpeg, ColorImage& out);

/// Encodes BGRA (alpha ignored) as JPEG, 4:2:0, `quality` 1..100, into `out` (resized, reused).
void encode_jpeg(const ColorImage& image, int quality, std::vector<uint8_t>& out);

}  // namespace volcast
