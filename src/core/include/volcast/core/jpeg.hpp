#pragma once
// JPEG through libjpeg-turbo's TurboJPEG API, BGRA in memory.
#include <cstdint>
#include <span>
#include <vector>

#include "volcast/core/image.hpp"

namespace volcast {

/// Decodes a baseline/progressive JPEG (any subsampling) to BGRA with A = 255. `out` is resized
/// and reused. Throws Error("corrupt JPEG: ...") on malformed or truncated data -- anything
/// libjpeg-turbo warns about (e.g. "Premature end of JPEG file") is an error, never a partly grey
/// image -- and Error("JPEG claims WxH pixels, ...") for a header beyond kMaxImageSide per side,
/// before allocating. `out` is unspecified after an error.
void decode_jpeg(std::span<const uint8_t> jpeg, ColorImage& out);

/// Reads the image size from a JPEG's headers (up to its frame header) without decoding it or
/// allocating for its pixels. Throws Error("corrupt JPEG: ...") if the headers cannot be read.
void jpeg_size(std::span<const uint8_t> jpeg, int& width, int& height);

/// Encodes BGRA (alpha ignored) as JPEG, 4:2:0, `quality` 1..100, into `out` (resized, reused).
void encode_jpeg(const ColorImage& image, int quality, std::vector<uint8_t>& out);

}  // namespace volcast
