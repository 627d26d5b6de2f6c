#pragma once
// Color codecs for BGRA images, picked by name (the table is in registry.hpp). Wire formats:
//   jpeg (lossy) - a plain baseline JPEG stream from libjpeg-turbo: 4:2:0, quality 90, no Volcast
//          header; decoded to BGRA with alpha 255 (alpha is not sent). Every frame stands alone.
//   raw (lossless) - a 12-byte header, then w * h * 4 bytes of BGRA, row-major. Header:
//          'V' 'C' | version 1 | codec id 0 | 4 zero bytes | width u16 | height u16
//          (little-endian). The decoder checks 'V' 'C' 1 and that the body is exactly w * h * 4
//          bytes; it does not read bytes 3-7.
//   h264 (lossy, temporal) - in volcast_codec_video (libavcodec); its header
//          volcast/codec_video/video_codecs.hpp documents the format. It shares the 12-byte
//          'V' 'C' header with codec id 2 and byte 4 bit 0 = key frame.
//   none - nothing: every frame is 0 bytes; the decoder ignores its input and yields an empty
//          (0 x 0) image.
// Color codec ids in byte 3 of the 'V' 'C' header: 0 raw, 2 h264 (1 is unused).
#include <cstdint>
#include <memory>
#include <optional>
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
  /// Sets the quality, 1..100 (higher is better and larger), before the first frame: JPEG quality
  /// (default 90); h264 CRF = round(51 - 0.45 * quality) (default CRF 23, about quality 62).
  /// Lossless and empty codecs ignore it. Throws Error outside 1..100.
  virtual void set_quality(int quality);
};

class ColorDecoder {
 public:
  virtual ~ColorDecoder() = default;
  /// Decodes into `out` (resized, reused). Throws Error on corrupt or truncated data.
  virtual void decode(std::span<const uint8_t> data, ColorImage& out) = 0;
};

/// The 12-byte header of Volcast's own color frames (raw, h264), above: its one writer and reader.
inline constexpr size_t kColorHeaderBytes = 12;
inline constexpr uint8_t kColorCodecRaw = 0;   ///< byte 3
inline constexpr uint8_t kColorCodecH264 = 2;  ///< byte 3
struct ColorHeader {
  uint8_t codec_id = kColorCodecRaw;
  bool key = true;  ///< byte 4 bit 0 (h264; raw frames write 0 there and are all key frames)
  int width = 0, height = 0;  ///< pixels, 0..65535
};
/// Writes `header` to out[0..11]; `out` must hold at least kColorHeaderBytes bytes.
void write_color_header(const ColorHeader& header, std::span<uint8_t> out);
/// The header at the start of `frame` if it has 12 bytes starting 'V' 'C' 1 (version), else
/// nullopt; the caller checks the codec id and the body.
std::optional<ColorHeader> read_color_header(std::span<const uint8_t> frame);

/// Names of the registered color codecs (registry.hpp), in registration order: jpeg, raw, none,
/// then h264 once volcast_codec_video's register_video_codecs() has run.
std::vector<std::string> color_codec_names();
/// A registered codec's encoder / decoder; throws Error("unknown color codec 'x' (available:
/// ...)").
std::unique_ptr<ColorEncoder> make_color_encoder(std::string_view name);
std::unique_ptr<ColorDecoder> make_color_decoder(std::string_view name);

}  // namespace volcast
