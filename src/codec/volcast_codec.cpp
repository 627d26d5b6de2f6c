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
//    never depend on the current row's values, so residuals decode ahead of reconstruction.
//  - Values are coded as a symbol (the value itself below 16; above, its bit length and the next
//    bit) with a per-context static rANS model (12-bit probabilities, tables sent with the frame,
//    two interleaved states), and the remaining low bits raw in a separate bit stream.
//  - Near-lossless (JPEG-LS's scheme): with a bound N > 0, residuals are quantised in steps of
//    2N+1 and the encoder predicts from its own reconstruction, so every valid pixel decodes within
//    N mm; which pixels are valid is always exact. N is stored in the header's byte 5.
// Body: table bytes u32 | tables | rANS bytes u32 | rANS stream | raw bit stream.
#include <algorithm>
#include <array>
#include <bit>

#include "frame_header.hpp"
#include "rans.hpp"

namespace volcast::detail {
namespace {

constexpr int kAlphabet = 64;
constexpr int kActivityContexts = 8;
constexpr int kBorderContext = 8;
constexpr int kZeroRunContext = 9;
constexpr int kValidRunContext = 10;
constexpr int kContexts = 11;
constexpr uint8_t kNoSymbol = 0xff;
constexpr int kMaxNear = 16;  // near-lossless error bounds up to 16 mm

inline uint32_t zigzag(int32_t v) {
  return (static_cast<uint32_t>(v) << 1) ^ static_cast<uint32_t>(v >> 31);
}
inline int32_t unzigzag(uint32_t u) {
  return static_cast<int32_t>(u >> 1) ^ -static_cast<int32_t>(u & 1);
}

// Value -> (symbol, raw bits). Values below 16 are their own symbol; above, the symbol names the
// bit length k and the bit below the leading one, and k-1 low bits go raw.
inline uint32_t symbol_of(uint32_t u, uint32_t& nbits, uint32_t& bits) {
  if (u < 16) {
    nbits = 0;
    return u;
  }
  const uint32_t k = 31u - static_cast<uint32_t>(std::countl_zero(u));
  nbits = k - 1;
  bits = u & ((1u << nbits) - 1);
  return 16 + (k - 4) * 2 + ((u >> (k - 1)) & 1);
}

// Context of the pixel at x: the local activity of the row above, |N-NW| + |NE-N|, in 8 levels
// (0 | 1-2 | 3-4 | 5-8 | 9-16 | 17-32 | 33-64 | 65+), or the border context where W, N, NW or NE
// is missing. It never depends on decoded values of the current row (only on which pixels are
// valid, known from the runs), so a decoder can decode a run's residuals ahead of reconstructing
// it.
inline int context_of(const uint16_t* up, int x, int w, bool w_valid) {
  if (!up || !w_valid || x + 1 >= w) return kBorderContext;
  const int32_t N = up[x], NW = up[x - 1], NE = up[x + 1];
  if (!N || !NW || !NE) return kBorderContext;
  const uint32_t activity = static_cast<uint32_t>(std::abs(N - NW) + std::abs(NE - N));
  const int level = activity == 0 ? 0 : std::max(1, static_cast<int>(std::bit_width(activity - 1)));
  return std::min(level, kActivityContexts - 1);
}

// Prediction of the pixel at x from its causal valid neighbours: LOCO-I's median edge detector on
// W, N, NW; else their mean or whichever exists; else `last`, the previous valid value.
inline int32_t predict(const uint16_t* row, const uint16_t* up, int x, int w, int32_t last) {
  const int32_t W = x > 0 ? row[x - 1] : 0;
  const int32_t N = up ? up[x] : 0;
  const int32_t NW = up && x > 0 ? up[x - 1] : 0;
  if (W && N && NW) {
    const int32_t lo = std::min(W, N), hi = std::max(W, N);
    return NW >= hi ? lo : (NW <= lo ? hi : W + N - NW);
  }
  if (W && N) return (W + N + 1) >> 1;
  if (W) return W;
  if (N) return N;
  if (NW) return NW;
  const int32_t NE = up && x + 1 < w ? up[x + 1] : 0;
  return NE ? NE : last;
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
    if (n == 0) return;
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
    if (n == 0) return 0;
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
    const int w = depth.width, h = depth.height;
    const size_t n = depth.size();
    symbols_.clear();
    symbols_.reserve(n + 2);
    bits_.reset(raw_bits_);
    std::array<std::array<uint32_t, kAlphabet>, kContexts> counts{};
    auto emit = [&](int context, uint32_t value) {
      uint32_t nbits, bits = 0;
      const uint32_t sym = symbol_of(value, nbits, bits);
      ++counts[context][sym];
      symbols_.push_back(static_cast<uint16_t>(context * kAlphabet + static_cast<int>(sym)));
      bits_.put(bits, nbits);
    };
    // Pass 1: runs, predictions, symbols and their statistics. Near-lossless predicts from the
    // values the decoder will reconstruct (closed loop), kept in recon_.
    const uint16_t* src = depth.pixels.data();
    if (near_ > 0) {
      recon_.width = depth.width;
      recon_.height = depth.height;
      recon_.pixels.assign(depth.pixels.begin(), depth.pixels.end());
    }
    uint16_t* rec = near_ > 0 ? recon_.pixels.data() : nullptr;
    const uint16_t* px = near_ > 0 ? rec : src;
    const int32_t step = 2 * near_ + 1;
    int32_t last = 0;
    size_t i = 0;
    while (i < n) {
      size_t start = i;
      while (i < n && px[i] == 0) ++i;
      emit(kZeroRunContext, static_cast<uint32_t>(i - start));
      start = i;
      while (i < n && px[i] != 0) ++i;
      emit(kValidRunContext, static_cast<uint32_t>(i - start));
      int y = static_cast<int>(start / static_cast<size_t>(w)),
          x = static_cast<int>(start % static_cast<size_t>(w));
      const uint16_t* row = px + static_cast<size_t>(y) * w;
      for (size_t j = start; j < i; ++j) {
        const uint16_t* up = y > 0 ? row - w : nullptr;
        const int32_t prediction = predict(row, up, x, w, last);
        int32_t residual = int32_t{src[j]} - prediction;
        if (near_ > 0) {
          // JPEG-LS near-lossless quantisation: |src - reconstruction| <= near_.
          residual = residual >= 0 ? (residual + near_) / step : -((near_ - residual) / step);
          rec[j] = static_cast<uint16_t>(std::clamp(prediction + residual * step, 1, 65535));
        }
        emit(context_of(up, x, w, j > start && x > 0), zigzag(residual));
        last = px[j];
        if (++x == w) x = 0, ++y, row += w;
      }
    }
    bits_.finish();
    (void)h;

    // Tables: per context a 64-bit presence mask, then each used symbol's frequency as a varint.
    tables_.clear();
    std::array<std::array<RansEncSymbol, kAlphabet>, kContexts> enc;
    for (int c = 0; c < kContexts; ++c) {
      uint32_t freqs[kAlphabet];
      normalize(counts[c].data(), freqs);
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
        enc[c][s].init(start, freqs[s]);
        start += freqs[s];
      }
    }
    // Pass 2: rANS, symbols in reverse.
    rans_.resize(symbols_.size() * 2 + 16);
    RansEncoder rans(rans_.data() + rans_.size());
    for (size_t k = symbols_.size(); k-- > 0;) {
      const uint16_t v = symbols_[k];
      rans.put(static_cast<int>(k & 1), enc[v / kAlphabet][v % kAlphabet]);
    }
    const uint8_t* rans_begin = rans.finish();
    const size_t rans_bytes = static_cast<size_t>(rans_.data() + rans_.size() - rans_begin);

    out.resize(kDepthHeaderBytes + 8 + tables_.size() + rans_bytes + raw_bits_.size());
    write_header(out.data(), kVolcast, true, w, depth.height);
    out[5] = static_cast<uint8_t>(near_);  // the error bound, in the header's first reserved byte
    uint8_t* p = out.data() + kDepthHeaderBytes;
    auto put32 = [&](size_t v) {
      for (int b = 0; b < 4; ++b) *p++ = static_cast<uint8_t>(v >> (8 * b));
    };
    put32(tables_.size());
    p = std::copy(tables_.begin(), tables_.end(), p);
    put32(rans_bytes);
    p = std::copy(rans_begin, static_cast<const uint8_t*>(rans_.data() + rans_.size()), p);
    std::copy(raw_bits_.begin(), raw_bits_.end(), p);
    return true;
  }
  std::string_view name() const override { return "volcast"; }

 private:
  int near_;
  DepthImage recon_;
  std::vector<uint16_t> symbols_;
  std::vector<uint8_t> raw_bits_, tables_, rans_;
  BitWriter bits_;
};

class VolcastDecoder final : public DepthDecoder {
 public:
  void decode(std::span<const uint8_t> data, DepthImage& out) override {
    const Header hdr = read_header(data, "volcast");
    const int near = data[5];
    if (near > kMaxNear)
      throw Error("volcast: corrupt header (error bound " + std::to_string(near) + " mm)");
    const int32_t step = 2 * near + 1;
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
    RansDecoder rans(p, p + rans_bytes);
    BitReader bits(p + rans_bytes, end);

    size_t symbol_index = 0;  // symbol k decodes on lane k % 2
    auto value = [&](int context) -> uint32_t {
      const int lane = static_cast<int>(symbol_index++ & 1);
      const uint32_t slot = rans.slot(lane);
      const uint8_t sym = lut_[context][slot];
      if (sym == kNoSymbol) throw Error("volcast: corrupt stream (symbol without a model)");
      rans.advance(lane, start_[context][sym], freq_[context][sym]);
      if (sym < 16) return sym;
      const uint32_t k = (sym - 16u) / 2 + 4, top = (sym - 16u) & 1;
      if (k > 31) throw Error("volcast: corrupt stream (value too long)");
      return (1u << k) | (top << (k - 1)) | bits.get(k - 1);
    };
    if (out.width != hdr.width || out.height != hdr.height) out = DepthImage(hdr.width, hdr.height);
    const int w = hdr.width;
    uint16_t* px = out.pixels.data();
    const size_t n = out.size();
    int32_t last = 0;
    size_t i = 0;
    while (i < n) {
      const uint32_t zeros = value(kZeroRunContext);
      if (zeros > n - i) throw Error("volcast: corrupt stream (run past the image)");
      std::fill(px + i, px + i + zeros, uint16_t{0});
      i += zeros;
      const uint32_t valid = value(kValidRunContext);
      if (valid > n - i) throw Error("volcast: corrupt stream (run past the image)");
      if (zeros == 0 && valid == 0 && i < n) throw Error("volcast: corrupt stream (empty run)");
      // Row by row (contexts read the row above, which must be complete): first the segment's
      // residuals, then its reconstruction, prediction by prediction.
      int y = static_cast<int>(i / static_cast<size_t>(w)),
          x = static_cast<int>(i % static_cast<size_t>(w));
      for (uint32_t left = valid; left > 0;) {
        const int segment =
            static_cast<int>(std::min<uint32_t>(left, static_cast<uint32_t>(w - x)));
        uint16_t* row = px + static_cast<size_t>(y) * w;
        const uint16_t* up = y > 0 ? row - w : nullptr;
        residuals_.resize(static_cast<size_t>(segment));
        for (int r = 0; r < segment; ++r)
          residuals_[r] =
              unzigzag(value(context_of(up, x + r, w, (left != valid || r > 0) && x + r > 0)));
        for (int r = 0; r < segment; ++r) {
          const int32_t prediction = predict(row, up, x + r, w, last);
          int32_t v = prediction + residuals_[r];
          if (near > 0) {
            if (std::abs(residuals_[r]) > 65535)
              throw Error("volcast: corrupt stream (residual out of range)");
            v = std::clamp(prediction + residuals_[r] * step, 1, 65535);
          }
          if (v <= 0 || v > 65535) throw Error("volcast: corrupt stream (value out of range)");
          row[x + r] = static_cast<uint16_t>(v);
          last = v;
        }
        left -= static_cast<uint32_t>(segment);
        x += segment;
        if (x == w) x = 0, ++y;
      }
      i += valid;
    }
  }

 private:
  void read_tables(const uint8_t* p, const uint8_t* end) {
    for (int c = 0; c < kContexts; ++c) {
      if (end - p < 8) throw Error("volcast: truncated tables");
      uint64_t mask = 0;
      for (int b = 0; b < 8; ++b) mask |= uint64_t{*p++} << (8 * b);
      std::fill(lut_[c].begin(), lut_[c].end(), kNoSymbol);
      uint32_t start = 0;
      for (int s = 0; s < kAlphabet; ++s) {
        start_[c][s] = freq_[c][s] = 0;
        if (!(mask >> s & 1)) continue;
        uint32_t f = 0;
        for (int shift = 0;; shift += 7) {
          if (p == end || shift > 14) throw Error("volcast: corrupt tables");
          const uint8_t byte = *p++;
          f |= uint32_t{byte & 0x7fu} << shift;
          if (!(byte & 0x80)) break;
        }
        if (f == 0 || start + f > kProbScale) throw Error("volcast: corrupt tables (frequencies)");
        start_[c][s] = start;
        freq_[c][s] = f;
        std::fill(lut_[c].begin() + start, lut_[c].begin() + start + f, static_cast<uint8_t>(s));
        start += f;
      }
      if (mask && start != kProbScale)
        throw Error("volcast: corrupt tables (frequencies do not sum up)");
    }
  }
  std::array<std::array<uint8_t, kProbScale>, kContexts> lut_{};
  std::vector<int32_t> residuals_;
  std::array<std::array<uint32_t, kAlphabet>, kContexts> start_{}, freq_{};
};

}  // namespace

std::unique_ptr<DepthEncoder> make_volcast_encoder(int near_mm) {
  return std::make_unique<VolcastEncoder>(near_mm);
}
std::unique_ptr<DepthDecoder> make_volcast_decoder() {
  return std::make_unique<VolcastDecoder>();
}

}  // namespace volcast::detail
