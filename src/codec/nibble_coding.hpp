#pragma once
// Internal: the variable-length nibble code shared by RVL and temporal RVL (Wilson 2017). A value
// is written 3 bits per nibble, least significant group first, with bit 3 set while more follow.
// Nibbles are packed most significant first into 32-bit little-endian words.
#include <cstdint>
#include <cstring>

#include "volcast/core/error.hpp"

namespace volcast::detail {

class NibbleWriter {
 public:
  explicit NibbleWriter(uint8_t* out) : out_(out) {}
  void put_vle(uint32_t value) {
    do {
      uint32_t nibble = value & 7;
      value >>= 3;
      if (value) nibble |= 8;
      word_ = (word_ << 4) | nibble;
      if (++count_ == 8) flush_word();
    } while (value);
  }
  /// Pads the last word and returns the number of bytes written.
  size_t finish() {
    if (count_) {
      word_ <<= 4 * (8 - count_);
      flush_word();
    }
    return written_;
  }

 private:
  void flush_word() {
    const uint32_t w = word_;
    const uint8_t b[4] = {uint8_t(w), uint8_t(w >> 8), uint8_t(w >> 16), uint8_t(w >> 24)};
    std::memcpy(out_ + written_, b, 4);
    written_ += 4;
    word_ = 0;
    count_ = 0;
  }
  uint8_t* out_;
  size_t written_ = 0;
  uint32_t word_ = 0;
  int count_ = 0;
};

class NibbleReader {
 public:
  NibbleReader(const uint8_t* data, size_t size, const char* codec)
      : data_(data), words_(size / 4), codec_(codec) {
    if (size % 4) throw Error(std::string(codec) + ": body is not a whole number of 32-bit words");
  }
  uint32_t get_vle() {
    uint32_t value = 0;
    for (int shift = 0; shift < 33; shift += 3) {
      if (count_ == 0) load_word();
      const uint32_t nibble = word_ >> 28;
      word_ <<= 4;
      --count_;
      value |= (nibble & 7) << shift;
      if (!(nibble & 8)) return value;
    }
    throw Error(std::string(codec_) + ": corrupt stream (variable-length value too long)");
  }

 private:
  void load_word() {
    if (next_ >= words_) throw Error(std::string(codec_) + ": truncated stream");
    const uint8_t* b = data_ + next_ * 4;
    word_ = uint32_t(b[0]) | uint32_t(b[1]) << 8 | uint32_t(b[2]) << 16 | uint32_t(b[3]) << 24;
    ++next_;
    count_ = 8;
  }
  const uint8_t* data_;
  size_t words_;
  size_t next_ = 0;
  uint32_t word_ = 0;
  int count_ = 0;
  const char* codec_;
};

inline uint32_t zigzag(int32_t v) {
  return (static_cast<uint32_t>(v) << 1) ^ static_cast<uint32_t>(v >> 31);
}
inline int32_t unzigzag(uint32_t u) {
  return static_cast<int32_t>(u >> 1) ^ -static_cast<int32_t>(u & 1);
}

/// Worst-case body size for n pixels: every pixel its own run pair (two 8-nibble counts at most)
/// plus a 6-nibble value, rounded up to words.
inline size_t max_body_bytes(size_t n) {
  return (n * 22 + 7) / 8 * 4 + 8;
}

}  // namespace volcast::detail
