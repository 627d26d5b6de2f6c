// Volcast's lossless depth codec ("volcast"): exact on every uint16 value.
//
// Structure, per frame (all static: two passes, no state between frames):
//  - The image is scanned in raster order as alternating runs, as in RVL: a run of invalid (0)
//    pixels, then a run of valid ones. Run lengths are entropy coded in their own two contexts.
//  - Each valid pixel is predicted from its causal valid neighbours: the LOCO-I / JPEG-LS median
//    edge detector (MED) on W, N, NW where all three are valid, else the mean or whichever exists,
//    else the previous valid value. The residual is zigzag mapped.
//  - Context = the local activity of the row above, |N-NW| + |NE-N|, quantised to 8 levels
//    (JPEG-LS's idea), plus one context for pixels on the border of the valid region. Contexts
//    never depend on the current row's values, so they are computed a row at a time
//    (vectorised) and the entropy decoder never waits on reconstruction.
//  - Values are coded as a symbol (the value itself below 16; above, its bit length and the next
//    bit) with a per-context static rANS model (12-bit probabilities, tables sent with the frame,
//    four interleaved states), and the remaining low bits raw in a separate bit stream.
//  - Near-lossless (JPEG-LS's scheme): with a bound N > 0, residuals are quantised in steps of
//    2N+1 and the encoder predicts from its own reconstruction, so every valid pixel decodes within
//    N mm; which pixels are valid is always exact. N is stored in the header's byte 5.
// Body: table bytes u32 | tables | rANS bytes u32 | rANS words | raw bit stream.
#include <algorithm>
#include <array>
#include <bit>

#include "frame_header.hpp"
#include "rans.hpp"

namespace volcast::detail {
namespace {

constexpr int kAlphabet = 64;
constexpr uint8_t kBorderContext = 8;
constexpr int kZeroRunContext = 9;
constexpr int kValidRunContext = 10;
constexpr int kContexts = 11;
constexpr int kMaxNear = 16;              // near-lossless error bounds up to 16 mm
constexpr uint32_t kLongFlag = 1u << 18;  // decoding table: a symbol with raw bits

// The 7 payload bits of a decoding table entry (entry bits 12-18): for run contexts the symbol;
// for pixel contexts, symbols below 16 carry the residual they stand for (zigzag decoded, 4-bit
// two's complement in entry bits 14-17) so the hot path needs no unzigzag, and longer symbols
// carry the symbol and the long flag.
inline uint32_t slot_payload(int context, uint32_t sym) {
  if (context >= kZeroRunContext) return sym;
  if (sym >= 16) return sym | kLongFlag >> 12;
  const int32_t residual = static_cast<int32_t>(sym >> 1) ^ -static_cast<int32_t>(sym & 1);
  return (static_cast<uint32_t>(residual) & 0xf) << 2;
}

inline uint32_t zigzag(int32_t v) {
  return (static_cast<uint32_t>(v) << 1) ^ static_cast<uint32_t>(v >> 31);
}
inline int32_t unzigzag(uint32_t u) {
  return static_cast<int32_t>(u >> 1) ^ -static_cast<int32_t>(u & 1);
}

// Value -> symbol for values of 16 and above: the bit length k and the bit below the leading one;
// k-1 low bits go raw. Values below 16 are their own symbol.
inline uint32_t long_symbol(uint32_t u, uint32_t& nbits, uint32_t& bits) {
  const uint32_t k = 31u - static_cast<uint32_t>(std::countl_zero(u));
  nbits = k - 1;
  bits = u & ((1u << nbits) - 1);
  return 16 + (k - 4) * 2 + ((u >> (k - 1)) & 1);
}

// Per-row model, computed from the row above only (`up`, all zeros for the first row), so the
// decoder's entropy decoding never waits on reconstruction and the pass vectorises:
//  - context: the local activity |N-NW| + |NE-N| in 8 levels (0 | 1-2 | 3-4 | 5-8 | 9-16 | 17-32 |
//    33-64 | 65+), or the border context where N, NW or NE is invalid or missing. The first pixel
//    of a run segment (W invalid or missing) also takes the border context; callers apply that.
//  - prediction of a pixel whose W is valid, as clamp(N, W + lo, W + hi): with N and NW valid,
//    lo = min(N-NW, 0) and hi = max(N-NW, 0), which is exactly LOCO-I's median edge detector
//    median(W, N, W+N-NW) with one add, one max and one min after W is known; with only N valid,
//    N (lo, hi = -/+65536); with N invalid, W (lo = hi = 0).
// Arrays of one fixed capacity, so that a loop reaches all of them from one base register.
struct RowModel {
  uint16_t n[kMaxSide];             // N, the row above
  uint16_t table_offset[kMaxSide];  // context * kProbScale, the decoder's table offset
  int32_t lo[kMaxSide], hi[kMaxSide];
  uint8_t context[kMaxSide];

  void compute(const uint16_t* up, int w) {
    std::copy(up, up + w, n);
    for (int x = 1; x < w; ++x) {
      const int32_t N = up[x], NW = up[x - 1];
      // Branch-free (masks) so that the loop vectorises.
      const int32_t g = N - NW;
      const int32_t n_valid = -static_cast<int32_t>(N != 0);
      const int32_t nw_valid = -static_cast<int32_t>(NW != 0);
      lo[x] = n_valid & ((nw_valid & std::min(g, 0)) | (~nw_valid & -65536));
      hi[x] = n_valid & ((nw_valid & std::max(g, 0)) | (~nw_valid & 65536));
    }
    for (int x = 1; x + 1 < w; ++x) {
      // In 16 bits: |N-NW| and |NE-N| capped at 65 sum to the same level as uncapped.
      const uint16_t N = up[x], NW = up[x - 1], NE = up[x + 1];
      const uint16_t d1 = std::min<uint16_t>(N > NW ? N - NW : NW - N, 65);
      const uint16_t d2 = std::min<uint16_t>(NE > N ? NE - N : N - NE, 65);
      const uint16_t a = static_cast<uint16_t>(d1 + d2);
      const uint16_t level = static_cast<uint16_t>((a >= 1) + (a >= 3) + (a >= 5) + (a >= 9) +
                                                   (a >= 17) + (a >= 33) + (a >= 65));
      const bool border = N == 0 || NW == 0 || NE == 0;
      context[x] = static_cast<uint8_t>(border ? kBorderContext : level);
    }
    context[0] = context[w - 1] = kBorderContext;
    for (int x = 0; x < w; ++x) table_offset[x] = static_cast<uint16_t>(context[x] * kProbScale);
  }
  int32_t predict(int x, int32_t W) const {
    return std::min(std::max(int32_t{n[x]}, W + lo[x]), W + hi[x]);
  }
};

// Prediction of the first pixel of a run segment, whose W is invalid or missing: N, NW, NE or
// `last`, the previous valid value.
inline int32_t predict_first(const uint16_t* up, int x, int w, int32_t last) {
  if (up[x]) return up[x];
  if (x > 0 && up[x - 1]) return up[x - 1];
  if (x + 1 < w && up[x + 1]) return up[x + 1];
  return last;
}

class BitWriter {
 public:
  void reset(std::vector<uint8_t>& out) {
    out_ = &out;
    out.clear();
    acc_ = 0;
    count_ = 0;
  }
  void put(uint32_t bits, uint32_t n) {
    acc_ |= uint64_t{bits} << count_;
    count_ += n;
    while (count_ >= 8) {
      out_->push_back(static_cast<uint8_t>(acc_));
      acc_ >>= 8;
      count_ -= 8;
    }
  }
  void finish() {
    if (count_ > 0) out_->push_back(static_cast<uint8_t>(acc_));
  }

 private:
  std::vector<uint8_t>* out_ = nullptr;
  uint64_t acc_ = 0;
  uint32_t count_ = 0;
};

class BitReader {
 public:
  BitReader(const uint8_t* p, const uint8_t* end) : p_(p), end_(end) {}
  uint32_t get(uint32_t n) {
    while (count_ < n) {
      if (p_ == end_) throw Error("volcast: truncated stream (raw bits)");
      acc_ |= uint64_t{*p_++} << count_;
      count_ += 8;
    }
    const uint32_t v = static_cast<uint32_t>(acc_ & ((uint64_t{1} << n) - 1));
    acc_ >>= n;
    count_ -= n;
    return v;
  }

 private:
  const uint8_t* p_;
  const uint8_t* end_;
  uint64_t acc_ = 0;
  uint32_t count_ = 0;
};

// Scales counts to frequencies summing to kProbScale, every used symbol at least 1.
void normalize(const uint32_t* counts, uint32_t* freqs) {
  uint64_t total = 0;
  for (int s = 0; s < kAlphabet; ++s) total += counts[s];
  std::fill(freqs, freqs + kAlphabet, 0u);
  if (total == 0) return;
  uint32_t sum = 0;
  int largest = 0;
  for (int s = 0; s < kAlphabet; ++s) {
    if (!counts[s]) continue;
    freqs[s] =
        std::max<uint32_t>(1, static_cast<uint32_t>(uint64_t{counts[s]} * kProbScale / total));
    sum += freqs[s];
    if (freqs[s] > freqs[largest]) largest = s;
  }
  // Put the rounding difference on the most frequent symbol; if that is not enough (many rare
  // symbols rounded up to 1), take from the others too.
  int32_t diff = static_cast<int32_t>(kProbScale) - static_cast<int32_t>(sum);
  if (static_cast<int32_t>(freqs[largest]) + diff >= 1) {
    freqs[largest] = static_cast<uint32_t>(static_cast<int32_t>(freqs[largest]) + diff);
    return;
  }
  for (int s = 0; diff < 0 && s < kAlphabet; s = (s + 1) % kAlphabet) {
    if (freqs[s] > 1) {
      --freqs[s];
      ++diff;
    }
  }
}

class VolcastEncoder final : public DepthEncoder {
 public:
  explicit VolcastEncoder(int near_mm) : near_(near_mm) {
    if (near_ < 0 || near_ > kMaxNear)
      throw Error("volcast: near-lossless bound must be 0.." + std::to_string(kMaxNear) + " mm");
  }
  bool encode(const DepthImage& depth, bool, std::vector<uint8_t>& out) override {
    check_size(depth);
    const size_t n = depth.size();
    symbols_.resize(2 * n + 2);  // at most two run symbols and one value per pixel
    count_ = 0;
    counts_.fill(0);
    bits_.reset(raw_bits_);
    if (near_ > 0) {
      recon_.width = depth.width;
      recon_.height = depth.height;
      recon_.pixels.assign(depth.pixels.begin(), depth.pixels.end());
      model<true>(depth);
    } else {
      model<false>(depth);
    }
    bits_.finish();
    write_tables();
    const size_t rans_bytes = entropy_code();

    out.resize(kDepthHeaderBytes + 8 + tables_.size() + rans_bytes + raw_bits_.size());
    write_header(out.data(), kVolcast, true, depth.width, depth.height);
    out[5] = static_cast<uint8_t>(near_);  // the error bound, in the header's first reserved byte
    uint8_t* p = out.data() + kDepthHeaderBytes;
    auto put32 = [&](size_t v) {
      for (int b = 0; b < 4; ++b) *p++ = static_cast<uint8_t>(v >> (8 * b));
    };
    put32(tables_.size());
    p = std::copy(tables_.begin(), tables_.end(), p);
    put32(rans_bytes);
    for (const uint16_t* wd = rans_begin_; wd != rans_.data() + rans_.size(); ++wd)
      *p++ = static_cast<uint8_t>(*wd), *p++ = static_cast<uint8_t>(*wd >> 8);
    std::copy(raw_bits_.begin(), raw_bits_.end(), p);
    return true;
  }
  std::string_view name() const override { return "volcast"; }

 private:
  void emit(int context, uint32_t value) {
    uint32_t sym = value;
    if (value >= 16) [[unlikely]] {
      uint32_t nbits, bits;
      sym = long_symbol(value, nbits, bits);
      bits_.put(bits, nbits);
    }
    const uint16_t v = static_cast<uint16_t>(context * kAlphabet + static_cast<int>(sym));
    ++counts_[v];
    symbols_[count_++] = v;
  }

  // Pass 1: runs, contexts, predictions, symbols and their statistics. Lossless residuals are
  // computed a row at a time (no dependency between pixels, so the loop vectorises);
  // near-lossless predicts from the values the decoder will reconstruct (closed loop), kept in
  // recon_, pixel by pixel.
  template <bool kNear>
  void model(const DepthImage& depth) {
    const int w = depth.width;
    const size_t n = depth.size();
    const uint16_t* src = depth.pixels.data();
    uint16_t* rec = recon_.pixels.data();
    const uint16_t* px = kNear ? rec : src;
    zero_row_.assign(static_cast<size_t>(w), 0);
    coded_.resize(static_cast<size_t>(w));
    int model_row = -1;
    const int32_t step = 2 * near_ + 1;
    // Exact division by `step` for numerators below 2^17 (the error of the rounded-up reciprocal
    // stays below 1/step).
    const uint64_t reciprocal =
        ((uint64_t{1} << 32) + static_cast<uint64_t>(step) - 1) / static_cast<uint64_t>(step);
    auto quantise = [&](size_t j, int32_t prediction) -> int32_t {
      // JPEG-LS near-lossless quantisation: |src - reconstruction| <= near_.
      const int32_t residual = int32_t{src[j]} - prediction;
      const int32_t q =
          residual >= 0
              ? static_cast<int32_t>((static_cast<uint64_t>(residual + near_) * reciprocal) >> 32)
              : -static_cast<int32_t>((static_cast<uint64_t>(near_ - residual) * reciprocal) >> 32);
      rec[j] = static_cast<uint16_t>(std::clamp(prediction + q * step, 1, 65535));
      return q;
    };
    int32_t last = 0;
    size_t i = 0;
    while (i < n) {
      size_t start = i;
      while (i < n && px[i] == 0) ++i;
      emit(kZeroRunContext, static_cast<uint32_t>(i - start));
      start = i;
      while (i < n && px[i] != 0) ++i;
      emit(kValidRunContext, static_cast<uint32_t>(i - start));
      // Row segments of the valid run: the first pixel of each (W invalid or missing) on the
      // general path, the others on the fast one.
      for (size_t j = start; j < i;) {
        const int y = static_cast<int>(j / static_cast<size_t>(w));
        const int x0 = static_cast<int>(j % static_cast<size_t>(w));
        const int x1 = static_cast<int>(std::min<size_t>(i - j + static_cast<size_t>(x0), w));
        const uint16_t* row = px + static_cast<size_t>(y) * w;
        const uint16_t* up = y > 0 ? row - w : zero_row_.data();
        if (y != model_row) {
          rows_.compute(up, w);
          model_row = y;
          if constexpr (!kNear) {
            for (int x = 1; x < w; ++x)
              coded_[x] = zigzag(int32_t{row[x]} - rows_.predict(x, row[x - 1]));
          }
        }
        const int32_t first = predict_first(up, x0, w, last);
        if constexpr (kNear) {
          emit(kBorderContext, zigzag(quantise(j, first)));
          for (int x = x0 + 1; x < x1; ++x) {
            const int32_t prediction = rows_.predict(x, row[x - 1]);
            emit(rows_.context[x], zigzag(quantise(j + static_cast<size_t>(x - x0), prediction)));
          }
        } else {
          emit(kBorderContext, zigzag(int32_t{row[x0]} - first));
          // The common case inline, with the counters in locals (no member stores per pixel).
          const uint8_t* ctx = rows_.context;
          const uint32_t* coded = coded_.data();
          uint16_t* symbols = symbols_.data();
          uint32_t* counts = counts_.data();
          size_t count = count_;
          for (int x = x0 + 1; x < x1; ++x) {
            if (coded[x] >= 16) [[unlikely]] {
              count_ = count;
              emit(ctx[x], coded[x]);
              count = count_;
              continue;
            }
            const uint16_t v = static_cast<uint16_t>(ctx[x] * kAlphabet + coded[x]);
            ++counts[v];
            symbols[count++] = v;
          }
          count_ = count;
        }
        last = row[x1 - 1];
        j += static_cast<size_t>(x1 - x0);
      }
    }
  }

  // Tables: per context a 64-bit presence mask, then each used symbol's frequency as a varint.
  void write_tables() {
    tables_.clear();
    for (int c = 0; c < kContexts; ++c) {
      uint32_t freqs[kAlphabet];
      normalize(counts_.data() + c * kAlphabet, freqs);
      uint64_t mask = 0;
      for (int s = 0; s < kAlphabet; ++s)
        if (freqs[s]) mask |= uint64_t{1} << s;
      for (int b = 0; b < 8; ++b) tables_.push_back(static_cast<uint8_t>(mask >> (8 * b)));
      uint32_t start = 0;
      for (int s = 0; s < kAlphabet; ++s) {
        if (!freqs[s]) continue;
        for (uint32_t f = freqs[s];; f >>= 7) {
          tables_.push_back(static_cast<uint8_t>((f & 0x7f) | (f >= 0x80 ? 0x80 : 0)));
          if (f < 0x80) break;
        }
        enc_[c * kAlphabet + s].init(start, freqs[s]);
        start += freqs[s];
      }
    }
  }

  // Pass 2: rANS over the symbols in reverse, symbol k on lane k % 4. Returns the byte count.
  size_t entropy_code() {
    rans_.resize(count_ + kRansLanes * 2);
    uint16_t* ptr = rans_.data() + rans_.size();
    uint32_t s[kRansLanes] = {kRansLow, kRansLow, kRansLow, kRansLow};
    size_t k = count_;
    for (; k % kRansLanes; --k) rans_put(s[(k - 1) % kRansLanes], ptr, enc_[symbols_[k - 1]]);
    uint32_t s0 = s[0], s1 = s[1], s2 = s[2], s3 = s[3];
    for (; k > 0; k -= kRansLanes) {
      rans_put(s3, ptr, enc_[symbols_[k - 1]]);
      rans_put(s2, ptr, enc_[symbols_[k - 2]]);
      rans_put(s1, ptr, enc_[symbols_[k - 3]]);
      rans_put(s0, ptr, enc_[symbols_[k - 4]]);
    }
    for (const uint32_t state : {s3, s2, s1, s0}) {
      *--ptr = static_cast<uint16_t>(state >> 16);
      *--ptr = static_cast<uint16_t>(state);
    }
    rans_begin_ = ptr;
    return static_cast<size_t>(rans_.data() + rans_.size() - ptr) * 2;
  }

  int near_;
  DepthImage recon_;
  std::vector<uint16_t> symbols_, zero_row_, rans_;
  size_t count_ = 0;
  const uint16_t* rans_begin_ = nullptr;
  std::vector<uint8_t> raw_bits_, tables_;
  std::vector<uint32_t> coded_;
  RowModel rows_;
  std::array<uint32_t, kContexts * kAlphabet> counts_{};
  std::array<RansEncSymbol, kContexts * kAlphabet> enc_{};
  BitWriter bits_;
};

class VolcastDecoder final : public DepthDecoder {
 public:
  void decode(std::span<const uint8_t> data, DepthImage& out) override {
    const Header hdr = read_header(data, "volcast");
    const int near = data[5];
    if (near > kMaxNear)
      throw Error("volcast: corrupt header (error bound " + std::to_string(near) + " mm)");
    const uint8_t* p = data.data() + kDepthHeaderBytes;
    const uint8_t* end = data.data() + data.size();
    auto get32 = [&]() -> size_t {
      if (end - p < 4) throw Error("volcast: truncated stream");
      const size_t v = size_t{p[0]} | size_t{p[1]} << 8 | size_t{p[2]} << 16 | size_t{p[3]} << 24;
      p += 4;
      return v;
    };
    const size_t table_bytes = get32();
    if (table_bytes > static_cast<size_t>(end - p)) throw Error("volcast: truncated tables");
    read_tables(p, p + table_bytes);
    p += table_bytes;
    const size_t rans_bytes = get32();
    if (rans_bytes > static_cast<size_t>(end - p)) throw Error("volcast: truncated stream");
    if (rans_bytes < kRansStateBytes || rans_bytes % 2)
      throw Error("volcast: corrupt stream (rANS length)");
    // The word stream, copied with zero padding so that the branch-free renormalisation may read
    // ahead: between two checks of the read position at most max(2, width) symbols are decoded,
    // each consuming at most 2 bytes.
    stream_.resize(rans_bytes + 2 * static_cast<size_t>(hdr.width) + 8);
    std::copy(p, p + rans_bytes, stream_.begin());
    std::fill(stream_.begin() + static_cast<ptrdiff_t>(rans_bytes), stream_.end(), uint8_t{0});
    BitReader bits(p + rans_bytes, end);
    if (out.width != hdr.width || out.height != hdr.height) out = DepthImage(hdr.width, hdr.height);
    if (near > 0) {
      reconstruct<true>(out, near, rans_bytes, bits);
    } else {
      reconstruct<false>(out, near, rans_bytes, bits);
    }
  }

 private:
  template <bool kNear>
  void reconstruct(DepthImage& out, int near, size_t rans_bytes, BitReader& bits) {
    const uint8_t* rp = stream_.data();
    const uint8_t* const rp_end = stream_.data() + rans_bytes;
    uint32_t s[kRansLanes];
    for (uint32_t& st : s) {
      st = uint32_t{rp[0]} | uint32_t{rp[1]} << 8 | uint32_t{rp[2]} << 16 | uint32_t{rp[3]} << 24;
      rp += 4;
      if (st < kRansLow || st >= (1u << 31)) throw Error("volcast: corrupt stream (rANS state)");
    }
    uint32_t s0 = s[0], s1 = s[1], s2 = s[2], s3 = s[3];
    auto long_value = [&](uint32_t sym) -> uint32_t {
      const uint32_t k = (sym - 16u) / 2 + 4, top = (sym - 16u) & 1;
      return (1u << k) | (top << (k - 1)) | bits.get(k - 1);
    };
    // One symbol from `state` in `context`. Contexts without a model decode as symbol 0 (see
    // read_tables); value() below rejects them where the stream structure depends on it.
    // One symbol from `state`: its residual (unzigzagged) for the pixel paths, its value for runs.
    auto decode_residual = [&](uint32_t& state, uint32_t table_offset) -> int32_t {
      const uint32_t entry = table_[table_offset + (state & (kProbScale - 1))];
      rans_advance(state, rp, entry);
      if (entry & kLongFlag) [[unlikely]]
        return unzigzag(long_value(entry >> 12 & 63));
      return static_cast<int32_t>(entry << 14) >> 28;
    };
    auto decode = [&](uint32_t& state, uint32_t table_offset) -> uint32_t {
      const uint32_t entry = table_[table_offset + (state & (kProbScale - 1))];
      rans_advance(state, rp, entry);
      const uint32_t sym = entry >> 12 & 63;
      return sym < 16 ? sym : long_value(sym);
    };
    // Each symbol decodes on lane 0, then the lanes rotate, so symbol k decodes on lane k % 4.
    auto rotate = [&] {
      const uint32_t t = s0;
      s0 = s1, s1 = s2, s2 = s3, s3 = t;
    };
    auto value = [&](int context) -> uint32_t {
      if (!has_model_[static_cast<size_t>(context)])
        throw Error("volcast: corrupt stream (symbol without a model)");
      const uint32_t v = decode(s0, static_cast<uint32_t>(context) * kProbScale);
      rotate();
      return v;
    };
    auto check_position = [&] {
      if (rp > rp_end) throw Error("volcast: truncated stream");
    };
    const int32_t step = 2 * near + 1;
    auto reconstructed = [&](int32_t prediction, int32_t residual) -> int32_t {
      int32_t v = prediction + residual;
      if constexpr (kNear) {
        if (std::abs(residual) > 65535)
          throw Error("volcast: corrupt stream (residual out of range)");
        v = std::clamp(prediction + residual * step, 1, 65535);
      }
      if (static_cast<uint32_t>(v - 1) >= 65535u) [[unlikely]]
        throw Error("volcast: corrupt stream (value out of range)");
      return v;
    };
    const int w = out.width;
    zero_row_.assign(static_cast<size_t>(w), 0);
    int model_row = -1;
    uint16_t* px = out.pixels.data();
    const size_t n = out.size();
    int32_t last = 0;
    size_t i = 0;
    while (i < n) {
      check_position();
      const uint32_t zeros = value(kZeroRunContext);
      if (zeros > n - i) throw Error("volcast: corrupt stream (run past the image)");
      std::fill(px + i, px + i + zeros, uint16_t{0});
      i += zeros;
      const uint32_t valid = value(kValidRunContext);
      if (valid > n - i) throw Error("volcast: corrupt stream (run past the image)");
      if (zeros == 0 && valid == 0 && i < n) throw Error("volcast: corrupt stream (empty run)");
      // Row segments of the run; the row above is complete when a segment starts.
      for (const size_t run_end = i + valid; i < run_end;) {
        check_position();
        const int y = static_cast<int>(i / static_cast<size_t>(w));
        const int x0 = static_cast<int>(i % static_cast<size_t>(w));
        const int x1 = static_cast<int>(std::min<size_t>(run_end - i + static_cast<size_t>(x0), w));
        uint16_t* row = px + static_cast<size_t>(y) * w;
        const uint16_t* up = y > 0 ? row - w : zero_row_.data();
        if (y != model_row) rows_.compute(up, w), model_row = y;
        if (!has_model_[kBorderContext])
          throw Error("volcast: corrupt stream (symbol without a model)");
        int32_t W = reconstructed(predict_first(up, x0, w, last),
                                  decode_residual(s0, kBorderContext * kProbScale));
        rotate();
        row[x0] = static_cast<uint16_t>(W);
        // The rest of the segment; W stays in a register (the dependency chain from one pixel to
        // the next is add, max, min, add) while four independent rANS chains decode ahead of it.
        // Unrolled by the lanes so no state moves.
        const RowModel& m = rows_;
        auto pixel = [&](uint32_t& state, int x) {
          const int32_t r = decode_residual(state, m.table_offset[x]);
          W = reconstructed(m.predict(x, W), r);
          row[x] = static_cast<uint16_t>(W);
        };
        int x = x0 + 1;
        for (; x + 4 <= x1; x += 4) {
          pixel(s0, x);
          pixel(s1, x + 1);
          pixel(s2, x + 2);
          pixel(s3, x + 3);
        }
        for (; x < x1; ++x) pixel(s0, x), rotate();
        last = W;
        i += static_cast<size_t>(x1 - x0);
      }
    }
    check_position();
  }

  void read_tables(const uint8_t* p, const uint8_t* end) {
    for (int c = 0; c < kContexts; ++c) {
      if (end - p < 8) throw Error("volcast: truncated tables");
      uint64_t mask = 0;
      for (int b = 0; b < 8; ++b) mask |= uint64_t{*p++} << (8 * b);
      uint32_t* table = table_.data() + static_cast<size_t>(c) * kProbScale;
      has_model_[static_cast<size_t>(c)] = mask != 0;
      if (!mask) {
        // Never used by a valid stream; decodes as symbol 0 consuming nothing, so a corrupt
        // stream cannot index outside the tables.
        std::fill(table, table + kProbScale, rans_slot_entry(kProbScale, 0, 0));
        continue;
      }
      uint32_t start = 0;
      for (int s = 0; s < kAlphabet; ++s) {
        if (!(mask >> s & 1)) continue;
        uint32_t f = 0;
        for (int shift = 0;; shift += 7) {
          if (p == end || shift > 14) throw Error("volcast: corrupt tables");
          const uint8_t byte = *p++;
          f |= uint32_t{byte & 0x7fu} << shift;
          if (!(byte & 0x80)) break;
        }
        if (f == 0 || start + f > kProbScale) throw Error("volcast: corrupt tables (frequencies)");
        const uint32_t payload = slot_payload(c, static_cast<uint32_t>(s));
        for (uint32_t o = 0; o < f; ++o) table[start + o] = rans_slot_entry(f, o, payload);
        start += f;
      }
      if (start != kProbScale) throw Error("volcast: corrupt tables (frequencies do not sum up)");
    }
  }

  // Per context and slot: rans_slot_entry(freq, offset, symbol).
  std::array<uint32_t, kContexts * kProbScale> table_{};
  std::array<bool, kContexts> has_model_{};
  std::vector<uint8_t> stream_;
  std::vector<uint16_t> zero_row_;
  RowModel rows_;  // beside table_, both reached from `this` (few registers in the hot loop)
};

}  // namespace

std::unique_ptr<DepthEncoder> make_volcast_encoder(int near_mm) {
  return std::make_unique<VolcastEncoder>(near_mm);
}
std::unique_ptr<DepthDecoder> make_volcast_decoder() {
  return std::make_unique<VolcastDecoder>();
}

}  // namespace volcast::detail
