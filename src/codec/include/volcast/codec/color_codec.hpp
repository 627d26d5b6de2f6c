#pragma once
// Color codecs for BGRA images, picked by name:
//   jpeg - libjpeg-turbo, 4:2:0, quality 90 by default; alpha is not kept (decodes as 255)
//   raw  - BGRA as is, behind a 12-byte header ('V' 'C' | version | 0 | 4 reserved | w u16 | h u16)
//   h264 - H.264 video (x264 through libavcodec: ultrafast, zerolatency, no B-frames, CRF 23),
//          4:2:0, even sides only; temporal: a viewer's decoder needs the stream from a key frame
//   none - no color is sent; decodes to an empty image
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "volcast/core/image.hpp"

namespace volcast {

class ColorEncoder {
 public:
  virtual ~ColorEncoder() = default;
  /// Encodes `image` into `out` (resized, reused). `key_frame` asks for a frame that decodes on
  /// its own (temporal codecs; the others always emit one). Returns true for a key frame.
  virtual bool encode(const ColorImage& image, bool key_frame, std::vector<uint8_t>& out) = 0;
  virtual std::string_view name() const = 0;
};

class ColorDecoder {
 public:
  virtual ~ColorDecoder() = default;
  /// Decodes into `out` (resized, reused). Throws Error on corrupt or truncated data.
  virtual void decode(std::span<const uint8_t> data, ColorImage& out) = 0;
};

std::vector<std::string> color_codec_names();
/// Throws Error("unknown color codec 'x' (available: ...)").
std::unique_ptr<ColorEncoder> make_color_encoder(std::string_view name);
std::unique_ptr<ColorDecoder> make_color_decoder(std::string_view name);

}  // namespace volcast
