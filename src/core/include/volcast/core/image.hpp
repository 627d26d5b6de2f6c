#pragma once
// Core image types. Row-major, tightly packed, origin at the top-left pixel.
#include <cstdint>
#include <vector>

namespace volcast {

/// The largest width or height the image decoders (PNG, JPEG) accept, pixels: the same as the
/// depth codecs' limit. A file claiming more is refused before anything is allocated for it.
inline constexpr int kMaxImageSide = 8192;

/// Depth image: width*height uint16 samples in millimetres; 0 means invalid (no measurement).
struct DepthImage {
  int width = 0;
  int height = 0;
  std::vector<uint16_t> pixels;  ///< size width*height, row-major

  DepthImage() = default;
  DepthImage(int w, int h) : width(w), height(h), pixels(static_cast<size_t>(w) * h, 0) {}
  uint16_t& at(int x, int y) { return pixels[static_cast<size_t>(y) * width + x]; }
  uint16_t at(int x, int y) const { return pixels[static_cast<size_t>(y) * width + x]; }
  size_t size() const { return pixels.size(); }
  bool operator==(const DepthImage&) const = default;
};

/// Color image: width*height pixels of 4 bytes in B, G, R, A order (A = 255, or 0 where a pixel
/// has no color, e.g. a depth pixel the color camera does not see after registration).
struct ColorImage {
  int width = 0;
  int height = 0;
  std::vector<uint8_t> bgra;  ///< size width*height*4, row-major

  ColorImage() = default;
  ColorImage(int w, int h) : width(w), height(h), bgra(static_cast<size_t>(w) * h * 4, 0) {}
  uint8_t* pixel(int x, int y) { return &bgra[(static_cast<size_t>(y) * width + x) * 4]; }
  const uint8_t* pixel(int x, int y) const {
    return &bgra[(static_cast<size_t>(y) * width + x) * 4];
  }
  bool empty() const { return bgra.empty(); }
  bool operator==(const ColorImage&) const = default;
};

}  // namespace volcast
