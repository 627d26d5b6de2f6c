#pragma once
// Depth codecs, picked by name. Every stream starts with a 12-byte header (little-endian):
//   'V' 'D' | version (2) | codec id | flags (bit 0: key frame) | 3 reserved zero bytes |
//   width u16 | height u16
// followed by the codec's body. Codecs:
//   raw  - uint16 little-endian samples (baseline for compression ratios)
//   rvl  - Run-length Variable Length coding (A. D. Wilson, "Fast Lossless Depth Image
//          Compression", ISS 2017), with 32-bit-safe deltas so every uint16 value round-trips
//   trvl - temporal RVL (H. Jun, J. Bailenson, "Temporal RVL", ISMAR 2020): key frames are RVL,
//          delta frames code the per-pixel change against the previous frame this encoder emitted.
//          Lossless by default (change threshold 0 mm, invalidation threshold 0 frames).
//   zstd - Zstandard (level 1) after a left-delta (mod 2^16) and low/high byte-plane split
//   lz4  - LZ4 after the same transform
//   volcast - Volcast's own: RVL-style runs of invalid/valid pixels, LOCO-I median prediction,
//          8 local-activity contexts and static rANS (see src/codec/volcast_codec.cpp)
//   volcast-t - volcast with temporal prediction: delta frames between key frames predict each
//          16x16 block from the last frame or spatially, whichever is cheaper (lossless)
//   volcast-n1, volcast-n2, volcast-n4 - near-lossless: every valid pixel within 1, 2 or 4 mm;
//          invalid pixels stay exactly invalid
//   h264, hevc - lossy video through libavcodec (x264 10-bit, x265 12-bit; ultrafast,
//          zerolatency, no B-frames, key frames on request): valid depth mapped linearly over the
//          last key frame's [min - 100, max + 100] mm range, values outside it clamped; the valid
//          mask exact (sent beside the video). See src/codec/video_codecs.cpp.
// All codecs but volcast-n*, h264 and hevc are bit-exact on every 16-bit value. Encoders are
// stateful (temporal codecs keep the last frame they emitted); one encoder per receiver, so a
// receiver that misses frames the encoder never produced still decodes the next delta frame.
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "volcast/core/image.hpp"

namespace volcast {

inline constexpr size_t kDepthHeaderBytes = 12;

class DepthEncoder {
 public:
  virtual ~DepthEncoder() = default;
  /// Encodes `depth` into `out` (resized; capacity reused across calls). `key_frame` forces a
  /// frame that decodes on its own; stateful codecs also emit one on their first frame or when the
  /// size changes. Returns true if the emitted frame is a key frame.
  virtual bool encode(const DepthImage& depth, bool key_frame, std::vector<uint8_t>& out) = 0;
  virtual std::string_view name() const = 0;
};

class DepthDecoder {
 public:
  virtual ~DepthDecoder() = default;
  /// Decodes one frame into `out` (resized, reused). Throws Error naming the problem for a
  /// truncated or corrupt stream, a stream of another codec, or a delta frame without its key
  /// frame; never reads or writes out of bounds.
  virtual void decode(std::span<const uint8_t> data, DepthImage& out) = 0;
};

/// Parameters of temporal RVL; the defaults are lossless. The paper's lossy setting is
/// change_threshold_mm = 10, invalidation_frames = 2.
struct TrvlParams {
  int change_threshold_mm = 0;  ///< changes of at most this many mm keep the previous value
  int invalidation_frames = 0;  ///< a pixel turning invalid keeps its value for this many frames
};

/// Names of the depth codecs: raw, rvl, trvl, zstd, lz4, volcast, volcast-t, volcast-n1,
/// volcast-n2, volcast-n4, h264, hevc.
std::vector<std::string> depth_codec_names();
/// Throws Error("unknown depth codec 'x' (available: ...)").
std::unique_ptr<DepthEncoder> make_depth_encoder(std::string_view name);
std::unique_ptr<DepthDecoder> make_depth_decoder(std::string_view name);

std::unique_ptr<DepthEncoder> make_trvl_encoder(const TrvlParams& params);

/// Reads the header: true if `data` is a key frame. Throws Error if the header is malformed.
bool depth_frame_is_key(std::span<const uint8_t> data);

}  // namespace volcast
