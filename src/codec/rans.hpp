#pragma once
// Internal: a byte-wise range asymmetric numeral system coder (rANS, J. Duda, "Asymmetric numeral
// systems", 2013), 32-bit state, 12-bit probabilities, with multiply-by-reciprocal encoding so no
// division runs per symbol. Two interleaved states ("lanes": symbol k uses lane k % 2) share one
// byte stream, so consecutive symbols decode without waiting on each other. The encoder writes
// backwards from the end of a buffer; symbols must be encoded in reverse order of decoding.
#include <cstdint>

#include "volcast/core/error.hpp"

namespace volcast::detail {

inline constexpr uint32_t kRansLow = 1u << 23;  // lower bound of the normalised state
inline constexpr int kProbBits = 12;
inline constexpr uint32_t kProbScale = 1u << kProbBits;

/// Per-symbol encoder constants (start and frequency in units of 1/kProbScale).
struct RansEncSymbol {
  uint32_t x_max = 0, rcp_freq = 0, bias = 0;
  uint32_t cmpl_freq = 0, rcp_shift = 0;

  void init(uint32_t start, uint32_t freq) {
    x_max = ((kRansLow >> kProbBits) << 8) * freq;
    cmpl_freq = kProbScale - freq;
    if (freq < 2) {
      // freq == 1: x / 1 = x; fold it into the bias with an all-ones reciprocal.
      rcp_freq = ~0u;
      rcp_shift = 0;
      bias = start + kProbScale - 1;
    } else {
      uint32_t shift = 0;
      while (freq > (1u << shift)) ++shift;
      rcp_freq = static_cast<uint32_t>(((uint64_t{1} << (shift + 31)) + freq - 1) / freq);
      rcp_shift = shift - 1;
      bias = start;
    }
    rcp_shift += 32;
  }
};

class RansEncoder {
 public:
  /// `end` is one past the last byte of the output buffer; bytes are written downwards.
  explicit RansEncoder(uint8_t* end) : ptr_(end) {}
  void put(int lane, const RansEncSymbol& s) {
    uint32_t x = state_[lane];
    while (x >= s.x_max) {
      *--ptr_ = static_cast<uint8_t>(x);
      x >>= 8;
    }
    const uint32_t q = static_cast<uint32_t>((uint64_t{x} * s.rcp_freq) >> s.rcp_shift);
    state_[lane] = x + s.bias + q * s.cmpl_freq;
  }
  /// Writes the final states (lane 1, then lane 0, each little-endian); returns the first byte.
  uint8_t* finish() {
    for (int lane = 1; lane >= 0; --lane)
      for (int i = 0; i < 4; ++i) *--ptr_ = static_cast<uint8_t>(state_[lane] >> (24 - 8 * i));
    return ptr_;
  }

 private:
  uint32_t state_[2] = {kRansLow, kRansLow};
  uint8_t* ptr_;
};

class RansDecoder {
 public:
  RansDecoder(const uint8_t* begin, const uint8_t* end) : ptr_(begin), end_(end) {
    if (end_ - ptr_ < 8) throw Error("rans: truncated stream");
    for (uint32_t& st : state_) {
      st = uint32_t{ptr_[0]} | uint32_t{ptr_[1]} << 8 | uint32_t{ptr_[2]} << 16 |
           uint32_t{ptr_[3]} << 24;
      ptr_ += 4;
      if (st < kRansLow) throw Error("rans: corrupt stream (state)");
    }
  }
  uint32_t slot(int lane) const { return state_[lane] & (kProbScale - 1); }
  /// Consumes, on `lane`, the symbol occupying [start, start + freq) that slot(lane) fell into.
  void advance(int lane, uint32_t start, uint32_t freq) {
    uint32_t x = freq * (state_[lane] >> kProbBits) + slot(lane) - start;
    while (x < kRansLow) {
      if (ptr_ == end_) throw Error("rans: truncated stream");
      x = (x << 8) | *ptr_++;
    }
    state_[lane] = x;
  }

 private:
  uint32_t state_[2] = {0, 0};
  const uint8_t* ptr_;
  const uint8_t* end_;
};

}  // namespace volcast::detail
