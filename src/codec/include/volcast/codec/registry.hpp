#pragma once
// The codec registry: one table of depth codecs and one of color codecs, each entry a name, what
// the codec guarantees, and its factories. make_depth_encoder("x") and friends look names up here.
//
// Who fills it, in a fixed order (no static-initialisation tricks):
//  - volcast_codec (this library, pure C++: no FFmpeg, no OpenGL) puts its own codecs in the
//    table the first time the table is used: depth raw, rvl, trvl, zstd, lz4, volcast,
//    volcast-t, volcast-n1, volcast-n2, volcast-n4; color jpeg, raw, none.
//  - volcast_codec_video (libavcodec) adds depth h264 and hevc and color h264 when its
//    register_video_codecs() is called (volcast/codec_video/video_codecs.hpp). A program that
//    links it calls that once at start-up, before it looks codecs up (the volcast CLI does so
//    first thing in main()); until then those names are unknown, and the error says so.
// Lookups and registration are thread-safe; entries are never removed, so references returned
// here stay valid for the life of the program. The order of the table is registration order.
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "volcast/codec/color_codec.hpp"
#include "volcast/codec/depth_codec.hpp"

namespace volcast {

struct DepthCodecInfo {
  std::string_view name;  ///< what a viewer asks for ("volcast-n2")
  uint8_t wire_id = 0;    ///< byte 3 of every frame it writes (see depth_codec.hpp)
  bool lossless = false;  ///< every uint16 image decodes bit-exactly
  /// The largest |decoded - source| on a valid pixel: 0 lossless, N > 0 near-lossless (invalid
  /// pixels stay exactly invalid), -1 lossy without a bound.
  int max_error_mm = -1;
  /// Delta frames refer to earlier frames: a decoder refuses a delta frame until it has decoded
  /// a key frame of the stream.
  bool temporal = false;
  std::string_view summary;  ///< one line for --help and docs
  std::unique_ptr<DepthEncoder> (*make_encoder)() = nullptr;
  std::unique_ptr<DepthDecoder> (*make_decoder)() = nullptr;
  /// CPU time to encode one pixel (ns, one thread): `volcast bench` on the shared recordings,
  /// GCC 12 release build, x86-64 (2026), rounded up over the sets. A relative cost: the server
  /// charges a tier's encoding against its CPU budget by it (ServerConfig::tier_cpu_budget).
  /// Negative: not measured (the server charges the costliest registered depth codec's figure).
  double encode_ns_per_pixel = -1;
};

struct ColorCodecInfo {
  std::string_view name;
  bool lossless = false;  ///< BGRA decodes bit-exactly
  bool temporal = false;  ///< as for depth: delta frames need the stream from a key frame
  std::string_view summary;
  std::unique_ptr<ColorEncoder> (*make_encoder)() = nullptr;
  std::unique_ptr<ColorDecoder> (*make_decoder)() = nullptr;
  /// As DepthCodecInfo::encode_ns_per_pixel, per color pixel (the color image is registered to
  /// the depth image: as many pixels). Negative: not measured (charged as the costliest color
  /// codec's figure).
  double encode_ns_per_pixel = -1;
};

/// Adds a codec. `info` must name a new codec, have both factories, and (depth) keep
/// lossless == (max_error_mm == 0); otherwise throws Error. The strings `info` views must live
/// for the life of the program (string literals).
void register_depth_codec(const DepthCodecInfo& info);
void register_color_codec(const ColorCodecInfo& info);

/// The entry for `name`, or nullptr.
const DepthCodecInfo* find_depth_codec(std::string_view name);
const ColorCodecInfo* find_color_codec(std::string_view name);
/// The entry for `name`; throws Error("unknown depth codec 'x' (available: ...)").
const DepthCodecInfo& depth_codec_info(std::string_view name);
const ColorCodecInfo& color_codec_info(std::string_view name);
/// Every registered codec, in registration order (a snapshot).
std::vector<DepthCodecInfo> all_depth_codecs();
std::vector<ColorCodecInfo> all_color_codecs();

/// An image size an encoded frame declares (pixels).
struct DeclaredSize {
  int width = 0, height = 0;
};
/// The size a depth frame declares in its 12-byte header (depth_codec.hpp; every depth codec
/// writes it), read without decoding, so that a receiver can refuse a frame of the wrong size
/// before a decoder allocates for it. std::nullopt when `frame` is shorter than the header or
/// does not start with 'V' 'D' (then it is no depth frame, and a decoder refuses it as such).
std::optional<DeclaredSize> declared_depth_size(std::span<const uint8_t> frame);
/// The size a color frame declares, by its own format: the 12-byte 'V' 'C' header (raw, h264;
/// color_codec.hpp) or a JPEG's frame header (jpeg: starts with FF D8). std::nullopt for an empty
/// frame (no color), another format, or headers that cannot be read (a decoder refuses those).
/// Allocates nothing for the image.
std::optional<DeclaredSize> declared_color_size(std::span<const uint8_t> frame);

/// For --help: every registered codec with what it guarantees, e.g. "raw (lossless), trvl
/// (lossless, temporal), volcast-n2 (within 2 mm), h264 (lossy, temporal)".
std::string depth_codec_help();
std::string color_codec_help();

}  // namespace volcast
