#pragma once
// Internal to the codec libraries (volcast_codec, volcast_codec_video): the 12-byte header every
// depth codec stream starts with (its layout is documented in volcast/codec/depth_codec.hpp).
// Not a stable interface.
#include <cstdint>
#include <cstring>
#include <span>
#include <string>

#include "volcast/codec/depth_codec.hpp"
#include "volcast/core/error.hpp"

namespace volcast::detail {

enum CodecId : uint8_t {
  kRaw = 0,
  kRvl = 1,
  kTrvl = 2,
  kZstd = 3,
  kLz4 = 4,
  kVolcast = 5,
  kH264 = 6,
  kHevc = 7
};
// 2: volcast uses 11-bit probabilities and quantises values (not residuals) when near-lossless.
inline constexpr uint8_t kVersion = 2;
inline constexpr uint8_t kKeyFlag = 1;
inline constexpr int kMaxSide = 8192;

inline const char* codec_label(uint8_t id) {
  static constexpr const char* kLabels[] = {"raw", "rvl",     "trvl", "zstd",
                                            "lz4", "volcast", "h264", "hevc"};
  return id < std::size(kLabels) ? kLabels[id] : "unknown";
}

/// Writes the header with bytes 5-7 zero; codecs that use them (volcast, h264, hevc) set them
/// afterwards.
inline void write_header(uint8_t* out, CodecId id, bool key, int w, int h) {
  const uint8_t header[kDepthHeaderBytes] = {'V',
                                             'D',
                                             kVersion,
                                             id,
                                             uint8_t(key ? kKeyFlag : 0),
                                             0,
                                             0,
                                             0,
                                             uint8_t(w),
                                             uint8_t(w >> 8),
                                             uint8_t(h),
                                             uint8_t(h >> 8)};
  std::memcpy(out, header, kDepthHeaderBytes);
}

struct Header {
  uint8_t codec;
  bool key;
  int width, height;
  size_t pixels() const { return static_cast<size_t>(width) * height; }
};

/// Validates magic, version, codec (must be `expect`) and size. Throws Error naming the problem.
inline Header read_header(std::span<const uint8_t> d, const char* expect) {
  if (d.size() < kDepthHeaderBytes) throw Error(std::string(expect) + ": truncated header");
  if (d[0] != 'V' || d[1] != 'D') throw Error(std::string(expect) + ": not a Volcast depth frame");
  if (d[2] != kVersion)
    throw Error(std::string(expect) + ": unsupported depth format version " + std::to_string(d[2]));
  Header h{d[3], (d[4] & kKeyFlag) != 0, d[8] | d[9] << 8, d[10] | d[11] << 8};
  if (std::strcmp(codec_label(h.codec), expect) != 0)
    throw Error(std::string(expect) + ": frame was encoded with codec '" + codec_label(h.codec) +
                "'");
  if (h.width <= 0 || h.height <= 0 || h.width > kMaxSide || h.height > kMaxSide)
    throw Error(std::string(expect) + ": implausible size " + std::to_string(h.width) + "x" +
                std::to_string(h.height));
  return h;
}

inline void check_size(const DepthImage& depth) {
  if (depth.width <= 0 || depth.height <= 0 || depth.width > kMaxSide || depth.height > kMaxSide ||
      depth.pixels.size() != static_cast<size_t>(depth.width) * depth.height)
    throw Error("depth encoder: invalid image size");
}

}  // namespace volcast::detail
