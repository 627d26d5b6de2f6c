#pragma once
// Internal: a range asymmetric numeral system coder (rANS, J. Duda, "Asymmetric numeral systems",
// 2013) in the word-renormalised form of F. Giesen's rans_word: 32-bit states kept in
// [2^15, 2^31), 11-bit probabilities (small decoding tables stay in L1), 16-bit words, at most one
// word moved per symbol (so the decoder renormalises without a branch). The encoder divides with a
// precomputed reciprocal (Alverson 1991, as in Giesen's ryg_rans), valid for states below 2^31.
// Four interleaved states ("lanes": symbol k uses lane k % 4) share one word stream, so four
// consecutive symbols decode without waiting on each other. The encoder writes backwards from the
// end of a buffer; symbols are encoded in reverse order of decoding.
#include <bit>
#include <cstdint>
#include <cstring>

namespace volcast::detail {

inline constexpr uint32_t kRansLow = 1u << 15;  // lower bound of a normalised state
inline constexpr int kProbBits = 11;
inline constexpr uint32_t kProbScale = 1u << kProbBits;
inline constexpr int kRansLanes = 4;
inline constexpr int kRansStateBytes = 4 * kRansLanes;  // the final states, lane 0 first

/// Per-symbol encoder constants (start and frequency in units of 1/kProbScale); 16 bytes.
struct RansEncSymbol {
  uint32_t x_max = 0, rcp_freq = 0, bias = 0;
  uint16_t cmpl_freq = 0, rcp_shift = 0;

  void init(uint32_t start, uint32_t freq) {
    x_max = ((kRansLow >> kProbBits) << 16) * freq;
    cmpl_freq = static_cast<uint16_t>(kProbScale - freq);
    if (freq < 2) {
      // freq == 1: x / 1 = x; fold it into the bias with an all-ones reciprocal.
      rcp_freq = ~0u;
      rcp_shift = 0;
      bias = start + kProbScale - 1;
    } else {
      uint16_t shift = 0;
      while (freq > (1u << shift)) ++shift;
      rcp_freq = static_cast<uint32_t>(((uint64_t{1} << (shift + 31)) + freq - 1) / freq);
      rcp_shift = static_cast<uint16_t>(shift - 1);
      bias = start;
    }
    rcp_shift = static_cast<uint16_t>(rcp_shift + 32);
  }
};

/// Encodes one symbol into state `x`, writing at most one 16-bit word below `ptr`; the word
/// below `ptr` must be writable (it is written whether or not the state flushes, without a
/// branch, and kept only when it does).
inline void rans_put(uint32_t& x, uint16_t*& ptr, const RansEncSymbol& s) {
  ptr[-1] = static_cast<uint16_t>(x);
  const uint32_t flushed = x >> 16;
#if defined(__x86_64__) && defined(__GNUC__)
  uint64_t back = 0;
  const uint64_t one = 1;
  asm("cmpl %[x_max], %[x]\n\t"
      "cmovael %[flushed], %[x]\n\t"
      "cmovaeq %[one], %[back]"
      : [x] "+r"(x), [back] "+r"(back)
      : [flushed] "r"(flushed), [one] "r"(one), [x_max] "rm"(s.x_max)
      : "cc");
  ptr -= back;
#else
  const uint32_t flush = x >= s.x_max;
  const uint32_t mask = 0u - flush;
  x = (x & ~mask) | (flushed & mask);
  ptr -= flush;
#endif
  const uint32_t q = static_cast<uint32_t>((uint64_t{x} * s.rcp_freq) >> s.rcp_shift);
  x += s.bias + q * s.cmpl_freq;
}

/// Decodes one symbol from state `x` given its slot's frequency and the slot's offset in the
/// symbol's range (slot = `x % kProbScale`). Reads the word at `ptr` and advances past it only if
/// the state needs it, without a branch; the caller guarantees 2 readable bytes at `ptr`
/// (padding).
inline void rans_advance(uint32_t& x, const uint8_t*& ptr, uint32_t freq, uint32_t offset) {
  x = freq * (x >> kProbBits) + offset;
  uint16_t word;
  std::memcpy(&word, ptr, 2);  // little-endian hosts; see the static_assert below
  // Conditional moves, not a branch: refills are unpredictable (about one symbol in eight), and
  // compilers turn a select into a branch here.
  const uint32_t refilled = x << 16 | word;
#if defined(__x86_64__) && defined(__GNUC__)
  uint64_t advance = 0;
  const uint64_t two = 2;
  asm("cmpl %[low], %[x]\n\t"
      "cmovbl %[refilled], %[x]\n\t"
      "cmovbq %[two], %[advance]"
      : [x] "+r"(x), [advance] "+r"(advance)
      : [refilled] "r"(refilled), [two] "r"(two), [low] "i"(kRansLow)
      : "cc");
  ptr += advance;
#else
  const uint32_t refill = x < kRansLow;
  const uint32_t mask = 0u - refill;
  x = (x & ~mask) | (refilled & mask);
  ptr += refill * 2;
#endif
}
static_assert(std::endian::native == std::endian::little, "rANS word I/O assumes little-endian");

}  // namespace volcast::detail
