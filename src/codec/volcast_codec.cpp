// Volcast's lossless depth codec ("volcast"): exact on every uint16 value.
//
// Structure, per frame (static models: two passes; no state between frames except in temporal
// streams):
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
//    bit) with a per-context static rANS model (11-bit probabilities, tables sent with the frame,
//    four interleaved states), and the remaining low bits raw in a separate bit stream.
//  - Temporal streams ("volcast-t"): between key frames, a delta frame chooses per 16x16 block
//    spatial prediction or the last frame's value (where valid), with 8 more contexts (the row
//    above's change since the last frame) and a bit per block after the header. Header byte 6 =
//    1 marks a temporal stream, byte 7 numbers its frames so that a lost frame is detected.
//  - Near-lossless: with a bound N > 0 the valid values are first quantised in steps of 2N+1
//    (see quantise()), the result coded losslessly, so every valid pixel decodes within N mm;
//    which pixels are valid is always exact. N is stored in the header's byte 5.
// Body: [delta frames: block modes, 1 bit each, row-major] | table bytes u32 | tables (11
// contexts, 19 in delta frames) | rANS bytes u32 | rANS words | raw bit stream.
#include <algorithm>
#include <array>
#include <bit>

#include "builtin_codecs.hpp"
#include "rans.hpp"
#include "volcast/codec/detail/frame_header.hpp"

// Vectorised passes are also built for AVX2 and picked at run time (function multi-versioning,
// GCC on x86-64); the default build targets baseline x86-64.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define VOLCAST_AVX2_CLONE [[gnu::target_clones("avx2", "default")]]
#else
#define VOLCAST_AVX2_CLONE
#endif

namespace volcast::detail {
namespace {

constexpr int kAlphabet = 64;
constexpr uint8_t kBorderContext = 8;
constexpr int kZeroRunContext = 9;
constexpr int kValidRunContext = 10;
constexpr int kSpatialContexts = 11;   // what a key frame's tables hold
constexpr int kTemporalContext0 = 11;  // 8 activity levels for pixels predicted from the last frame
constexpr int kContexts = 19;          // what a delta frame's tables hold
constexpr int kBlock = 16;             // side of a temporal prediction block, pixels
inline bool is_pixel_context(int c) {
  return c != kZeroRunContext && c != kValidRunContext;
}
constexpr int kSymbolShift = kProbBits - 6;  // context * kProbScale >> it = context * kAlphabet
static_assert(kAlphabet == 64 && kProbBits >= 6);
constexpr int kMaxNear = 16;  // near-lossless error bounds up to 16 mm
// The largest symbol of a zigzagged residual: |residual| <= 65535 needs at most 17 bits (k = 16).
constexpr int8_t kLongResidual = -128;  // decoding: the slot's symbol has raw bits
constexpr int kMaxResidualSymbol = 16 + (16 - 4) * 2 + 1;

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
//  - prediction of a pixel whose W is valid, as clamp(N, W - down, W + up): with N and NW valid,
//    down = max(NW-N, 0) and up = max(N-NW, 0), which is exactly LOCO-I's median edge detector
//    median(W, N, W+N-NW) with a subtract, an add, one max and one min after W is known; with
//    only N valid, N (down = up = 65535, wider than any |N - W|); with N invalid, W (0, 0).
// All in 16 bits, so the pass runs 16 pixels to an AVX2 vector. Arrays of one fixed capacity, so
// that a loop reaches all of them from one base register.
struct RowModel {
  uint16_t n[kMaxSide];             // N, the row above
  uint16_t table_offset[kMaxSide];  // context * kProbScale, the decoder's table offset
  uint16_t down[kMaxSide], up[kMaxSide];

  void compute(const uint16_t* above, int w);
  int32_t predict(int x, int32_t W) const {
    return std::min(std::max(int32_t{n[x]}, W - int32_t{down[x]}), W + int32_t{up[x]});
  }
};

// |a - b| parts in 16 bits: max(a - b, 0).
inline uint16_t positive_difference(uint16_t a, uint16_t b) {
  return static_cast<uint16_t>(a > b ? a - b : 0);
}

// One pass over the row above, vectorised (branch-free: masks and selects).
VOLCAST_AVX2_CLONE
void compute_row_model(RowModel& m, const uint16_t* above, int w) {
  std::copy(above, above + w, m.n);
  auto prediction = [&](int x, uint16_t N, uint16_t NW, uint16_t rise, uint16_t fall) {
    const uint16_t n_valid = static_cast<uint16_t>(-(N != 0));
    const uint16_t nw_valid = static_cast<uint16_t>(-(NW != 0));
    const uint16_t nw_invalid = static_cast<uint16_t>(~nw_valid);
    m.down[x] = static_cast<uint16_t>(n_valid & ((nw_valid & fall) | nw_invalid));
    m.up[x] = static_cast<uint16_t>(n_valid & ((nw_valid & rise) | nw_invalid));
  };
  for (int x = 1; x + 1 < w; ++x) {
    const uint16_t N = above[x], NW = above[x - 1], NE = above[x + 1];
    const uint16_t rise = positive_difference(N, NW), fall = positive_difference(NW, N);
    prediction(x, N, NW, rise, fall);
    // |N-NW| and |NE-N| capped at 65 sum to the same level as uncapped.
    const uint16_t d1 = std::min<uint16_t>(static_cast<uint16_t>(rise | fall), 65);
    const uint16_t d2 = std::min<uint16_t>(
        static_cast<uint16_t>(positive_difference(NE, N) | positive_difference(N, NE)), 65);
    const uint16_t a = static_cast<uint16_t>(d1 + d2);
    const uint16_t level = static_cast<uint16_t>((a >= 1) + (a >= 3) + (a >= 5) + (a >= 9) +
                                                 (a >= 17) + (a >= 33) + (a >= 65));
    const uint16_t border = static_cast<uint16_t>(-((N == 0) | (NW == 0) | (NE == 0)));
    const uint16_t context = static_cast<uint16_t>((border & kBorderContext) | (~border & level));
    m.table_offset[x] = static_cast<uint16_t>(context << kProbBits);
  }
  if (w > 1) {
    const uint16_t N = above[w - 1], NW = above[w - 2];
    prediction(w - 1, N, NW, positive_difference(N, NW), positive_difference(NW, N));
  }
  // The first pixel's prediction is never used (a row segment's first pixel is predicted by
  // predict_first); both ends take the border context.
  m.table_offset[0] = m.table_offset[w - 1] = kBorderContext << kProbBits;
}

// Delta frames: pixels of temporal blocks (mask[x] != 0) whose previous value is valid are
// predicted as that value (clamp(prev, W - 65535, W + 65535) = prev), in the temporal contexts:
// the activity is the change of the row above since the last frame, |N - N'| + |NE - NE'|, in
// the same 8 levels (7 where any of them is invalid). One vectorised pass after the spatial one.
VOLCAST_AVX2_CLONE
void apply_temporal(RowModel& m, const uint16_t* above, const uint16_t* prev_row,
                    const uint16_t* prev_above, const uint8_t* mask, int w) {
  auto pixel = [&](int x, uint16_t NE, uint16_t PNE) {
    const uint16_t P = prev_row[x], N = above[x], PN = prev_above[x];
    const uint16_t temporal = static_cast<uint16_t>(-((mask[x] != 0) & (P != 0)));
    const uint16_t d1 = std::min<uint16_t>(
        static_cast<uint16_t>(positive_difference(N, PN) | positive_difference(PN, N)), 65);
    const uint16_t d2 = std::min<uint16_t>(
        static_cast<uint16_t>(positive_difference(NE, PNE) | positive_difference(PNE, NE)), 65);
    const uint16_t a = static_cast<uint16_t>(d1 + d2);
    const uint16_t invalid =
        static_cast<uint16_t>(-((N == 0) | (PN == 0) | (NE == 0) | (PNE == 0)));
    const uint16_t level = static_cast<uint16_t>(
        (invalid & 7) | (~invalid & ((a >= 1) + (a >= 3) + (a >= 5) + (a >= 9) + (a >= 17) +
                                     (a >= 33) + (a >= 65))));
    const uint16_t offset = static_cast<uint16_t>((kTemporalContext0 + level) << kProbBits);
    m.n[x] = static_cast<uint16_t>((temporal & P) | (~temporal & m.n[x]));
    m.down[x] = static_cast<uint16_t>(temporal | m.down[x]);
    m.up[x] = static_cast<uint16_t>(temporal | m.up[x]);
    m.table_offset[x] =
        static_cast<uint16_t>((temporal & offset) | (~temporal & m.table_offset[x]));
  };
  for (int x = 0; x + 1 < w; ++x) pixel(x, above[x + 1], prev_above[x + 1]);
  pixel(w - 1, above[w - 1], prev_above[w - 1]);  // no NE: N stands in
}

// min(bit_width(z), 9): about a residual's code length, branch-free.
inline uint32_t bit_length_capped(uint32_t z) {
  return (z > 0) + (z > 1) + (z > 3) + (z > 7) + (z > 15) + (z > 31) + (z > 63) + (z > 127) +
         (z > 255);
}

// Encoding, delta frames: adds each pixel's spatial and temporal cost (zigzagged residual capped
// at 64) to the column sums; invalid pixels cost nothing. One pass, vectorised.
VOLCAST_AVX2_CLONE
void block_costs(const uint16_t* row, const uint16_t* prev, const uint32_t* coded, int w,
                 uint32_t* spatial, uint32_t* temporal) {
  for (int x = 0; x < w; ++x) {
    const uint32_t valid = 0u - (row[x] != 0), prev_valid = 0u - (prev[x] != 0);
    const uint32_t s = bit_length_capped(coded[x]) & valid;
    const uint32_t t = bit_length_capped(zigzag(int32_t{row[x]} - int32_t{prev[x]}));
    spatial[x] += s;
    temporal[x] += (prev_valid & t & valid) | (~prev_valid & s);
  }
}

// Per pixel of row y: whether its block is temporal (modes: one byte per block, row-major).
void expand_modes(const std::vector<uint8_t>& modes, int y, int w, std::vector<uint8_t>& mask) {
  const int blocks_x = (w + kBlock - 1) / kBlock;
  mask.resize(static_cast<size_t>(w));
  for (int bx = 0; bx < blocks_x; ++bx) {
    const int x0 = bx * kBlock, x1 = std::min(w, x0 + kBlock);
    std::fill(mask.begin() + x0, mask.begin() + x1,
              modes[static_cast<size_t>(y / kBlock * blocks_x + bx)]);
  }
}

inline void RowModel::compute(const uint16_t* above, int w) {
  compute_row_model(*this, above, w);
}

// Encoding: the zigzagged residual of every pixel of `row` whose W is valid, from the row
// model; one pass, vectorised.
VOLCAST_AVX2_CLONE
void row_residuals(const RowModel& m, const uint16_t* row, int w, uint32_t* coded) {
  for (int x = 1; x < w; ++x) coded[x] = zigzag(int32_t{row[x]} - m.predict(x, row[x - 1]));
}

// Prediction of the first pixel of a run segment, whose W is invalid or missing: N, NW, NE or
// `last`, the previous valid value.
inline int32_t predict_first(const uint16_t* up, int x, int w, int32_t last) {
  if (up[x]) return up[x];
  if (x > 0 && up[x - 1]) return up[x - 1];
  if (x + 1 < w && up[x + 1]) return up[x + 1];
  return last;
}

// Sets up the model of row y of `image` (w wide): spatial from the row above, then, in delta
// frames (`prev`: the last frame, non-null), the temporal pass over the blocks in `modes`, whose
// per-pixel mask is left in `mask`. Shared by encoder and decoder, which must agree exactly.
void prepare_row(RowModel& m, std::vector<uint8_t>& mask, const std::vector<uint8_t>& modes,
                 const uint16_t* image, const uint16_t* prev, const uint16_t* zero_row, int y,
                 int w) {
  const size_t at = static_cast<size_t>(y) * static_cast<size_t>(w);
  const uint16_t* above = y > 0 ? image + at - w : zero_row;
  m.compute(above, w);
  if (!prev) return;
  expand_modes(modes, y, w, mask);
  apply_temporal(m, above, prev + at, y > 0 ? prev + at - w : zero_row, mask.data(), w);
}

// Prediction of the first pixel (x0, y) of a row segment: the last frame's value in a temporal
// block where it is valid, else predict_first.
inline int32_t first_prediction(const std::vector<uint8_t>& mask, const uint16_t* image,
                                const uint16_t* prev, const uint16_t* zero_row, int y, int x0,
                                int w, int32_t last) {
  const size_t at = static_cast<size_t>(y) * static_cast<size_t>(w);
  if (prev && mask[static_cast<size_t>(x0)] && prev[at + x0]) return prev[at + x0];
  return predict_first(y > 0 ? image + at - w : zero_row, x0, w, last);
}

// Near-lossless by quantising the values themselves (step 2N+1): q = ceil(d / step), so 0 stays 0
// (invalid) and every valid depth maps to q >= 1; the decoder reconstructs q*step - N, capped at
// 65535, which is within N of every d in ((q-1)*step, q*step]. The quantised image is then coded
// losslessly, so near-lossless costs one vectorised pass on each side and no serial closed loop.
VOLCAST_AVX2_CLONE
void quantise_values(const uint16_t* depth, size_t count, int near, uint16_t* q) {
  // floor((d + 2N) / step) in single precision, exact: (v + 0.5) / step is at least 0.5 / step
  // away from an integer, and the float error stays below v * 2^-23 / step <= 2^-6 / step.
  const float inverse = 1.0f / static_cast<float>(2 * near + 1);
  const float bias = static_cast<float>(2 * near) + 0.5f;
  for (size_t i = 0; i < count; ++i)
    q[i] = static_cast<uint16_t>(
        static_cast<int32_t>((static_cast<float>(depth[i]) + bias) * inverse));
}

void quantise(const DepthImage& depth, int near, DepthImage& q) {
  q.width = depth.width;
  q.height = depth.height;
  q.pixels.resize(depth.pixels.size());
  quantise_values(depth.pixels.data(), depth.pixels.size(), near, q.pixels.data());
}

VOLCAST_AVX2_CLONE
void dequantise(const uint16_t* q, size_t count, int near, uint16_t* out) {
  const int32_t step = 2 * near + 1;
  for (size_t i = 0; i < count; ++i) {
    const int32_t v = std::min(int32_t{q[i]} * step - near, 65535);
    out[i] = static_cast<uint16_t>(q[i] ? v : 0);
  }
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

// Decoding: the value of a long symbol, its low bits from the raw stream (the cold path).
[[gnu::noinline]] uint32_t long_value(uint32_t sym, BitReader& bits) {
  const uint32_t k = (sym - 16u) / 2 + 4, top = (sym - 16u) & 1;
  return (1u << k) | (top << (k - 1)) | bits.get(k - 1);
}

// The decoder's tables, per context and slot (context * kProbScale + x % kProbScale), in
// separate arrays so that each field is one load: the frequency of the symbol whose range holds
// the slot, the slot's offset in that range, the symbol, and for pixel contexts the residual a
// symbol below 16 stands for (kLongResidual for longer symbols).
struct DecodeTables {
  std::array<uint16_t, kContexts * kProbScale> freq, offset;
  std::array<uint8_t, kContexts * kProbScale> symbol;
  std::array<int8_t, kContexts * kProbScale> residual;
};

// One run-length symbol from `state` in `context`: its value.
inline uint32_t next_value(const DecodeTables& t, int context, uint32_t& state, const uint8_t*& p,
                           BitReader& bits) {
  const uint32_t slot = static_cast<uint32_t>(context) * kProbScale + (state & (kProbScale - 1));
  rans_advance(state, p, t.freq[slot], t.offset[slot]);
  const uint32_t sym = t.symbol[slot];
  return sym < 16 ? sym : long_value(sym, bits);
}

// One pixel symbol from `state` in the context whose tables start at `table_offset`: its residual.
inline int32_t next_residual(const DecodeTables& t, uint32_t table_offset, uint32_t& state,
                             const uint8_t*& p, BitReader& bits) {
  const uint32_t slot = table_offset + (state & (kProbScale - 1));
  rans_advance(state, p, t.freq[slot], t.offset[slot]);
  int32_t r = t.residual[slot];
  if (r == kLongResidual) [[unlikely]]
    r = unzigzag(long_value(t.symbol[slot], bits));
  return r;
}

class VolcastEncoder final : public DepthEncoder {
 public:
  VolcastEncoder(int near_mm, bool temporal)
      : near_(near_mm),
        temporal_(temporal),
        name_(std::string(temporal ? "volcast-t" : "volcast") +
              (near_mm > 0 ? "-n" + std::to_string(near_mm) : "")) {
    if (near_ < 0 || near_ > kMaxNear)
      throw Error("volcast: near-lossless bound must be 0.." + std::to_string(kMaxNear) + " mm");
  }
  bool encode(const DepthImage& depth, bool key_frame, std::vector<uint8_t>& out) override {
    check_size(depth);
    const size_t n = depth.size();
    symbols_.resize(2 * n + 2);  // at most two run symbols and one value per pixel
    count_ = 0;
    bits_.reset(raw_bits_);
    // The image the decoder reconstructs exactly: the depth itself, or its quantised values.
    if (near_ > 0) quantise(depth, near_, quantised_);
    const DepthImage& exact = near_ > 0 ? quantised_ : depth;
    const bool key =
        !temporal_ || key_frame || prev_.width != depth.width || prev_.height != depth.height;
    if (!key) choose_modes(exact);
    model(exact, key ? nullptr : prev_.pixels.data());
    bits_.finish();
    count_symbols();
    const int contexts = key ? kSpatialContexts : kContexts;
    write_tables(contexts);
    const size_t rans_bytes = entropy_code();

    const size_t mode_bytes = key ? 0 : (modes_.size() + 7) / 8;
    out.resize(kDepthHeaderBytes + mode_bytes + 8 + tables_.size() + rans_bytes + raw_bits_.size());
    write_header(out.data(), kVolcast, key, depth.width, depth.height);
    out[5] = static_cast<uint8_t>(near_);  // header bytes 5-7: see depth_codec.hpp
    out[6] = temporal_ ? 1 : 0;            // a temporal stream: delta frames may follow
    out[7] = sequence_++;                  // a delta frame refers to the frame numbered one less
    uint8_t* p = out.data() + kDepthHeaderBytes;
    std::fill(p, p + mode_bytes, uint8_t{0});
    for (size_t b = 0; b < (key ? 0 : modes_.size()); ++b)
      p[b / 8] = static_cast<uint8_t>(p[b / 8] | modes_[b] << (b % 8));
    p += mode_bytes;
    auto put32 = [&](size_t v) {
      for (int b = 0; b < 4; ++b) *p++ = static_cast<uint8_t>(v >> (8 * b));
    };
    put32(tables_.size());
    p = std::copy(tables_.begin(), tables_.end(), p);
    put32(rans_bytes);
    for (const uint16_t* wd = rans_begin_; wd != rans_.data() + rans_.size(); ++wd)
      *p++ = static_cast<uint8_t>(*wd), *p++ = static_cast<uint8_t>(*wd >> 8);
    std::copy(raw_bits_.begin(), raw_bits_.end(), p);
    if (temporal_) prev_ = exact;  // what the decoder will hold (copied into existing storage)
    return key;
  }
  std::string_view name() const override { return name_; }  // the registry's name

 private:
  void emit(int context, uint32_t value) {
    uint32_t sym = value;
    if (value >= 16) [[unlikely]] {
      uint32_t nbits, bits;
      sym = long_symbol(value, nbits, bits);
      bits_.put(bits, nbits);
    }
    const uint16_t v = static_cast<uint16_t>(context * kAlphabet + static_cast<int>(sym));
    symbols_[count_++] = v;
  }

  // Delta frames: per block, temporal prediction where its residuals are smaller than the
  // spatial ones (sum of zigzagged residuals capped at 64, a proxy of their code length; pixels
  // whose last value is invalid count as spatial on both sides).
  void choose_modes(const DepthImage& depth) {
    const int w = depth.width, h = depth.height;
    const int blocks_x = (w + kBlock - 1) / kBlock;
    modes_.assign(static_cast<size_t>(blocks_x) * static_cast<size_t>((h + kBlock - 1) / kBlock),
                  0);
    cost_.assign(2 * static_cast<size_t>(w), 0);  // per column: spatial, then temporal
    coded_.resize(static_cast<size_t>(w));
    zero_row_.assign(static_cast<size_t>(w), 0);
    for (int y = 0; y < h; ++y) {
      const uint16_t* row = depth.pixels.data() + static_cast<size_t>(y) * w;
      const uint16_t* prev = prev_.pixels.data() + static_cast<size_t>(y) * w;
      rows_.compute(y > 0 ? row - w : zero_row_.data(), w);
      row_residuals(rows_, row, w, coded_.data());
      coded_[0] = 0;
      block_costs(row, prev, coded_.data(), w, cost_.data(), cost_.data() + w);
      if ((y + 1) % kBlock == 0 || y + 1 == h) {
        for (int bx = 0; bx < blocks_x; ++bx) {
          const int x0 = bx * kBlock, x1 = std::min(w, x0 + kBlock);
          uint32_t spatial = 0, temporal = 0;
          for (int x = x0; x < x1; ++x) spatial += cost_[x], temporal += cost_[w + x];
          modes_[static_cast<size_t>(y / kBlock * blocks_x + bx)] = temporal < spatial;
        }
        std::fill(cost_.begin(), cost_.end(), 0u);
      }
    }
  }

  // Pass 1: runs, contexts, predictions, symbols and their statistics. Residuals are computed a
  // row at a time (no dependency between pixels, so the loop vectorises). `prev`: the last
  // frame's exact values for a delta frame (block modes in modes_), else null.
  void model(const DepthImage& depth, const uint16_t* prev) {
    const int w = depth.width;
    const size_t n = depth.size();
    const uint16_t* px = depth.pixels.data();
    zero_row_.assign(static_cast<size_t>(w), 0);
    coded_.resize(static_cast<size_t>(w));
    int model_row = -1;
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
        if (y != model_row) {
          prepare_row(rows_, mask_, modes_, px, prev, zero_row_.data(), y, w);
          model_row = y;
          row_residuals(rows_, row, w, coded_.data());
        }
        const int32_t first = first_prediction(mask_, px, prev, zero_row_.data(), y, x0, w, last);
        emit(kBorderContext, zigzag(int32_t{row[x0]} - first));
        // The common case inline, with the counter in a local (no member stores per pixel).
        const uint16_t* offsets = rows_.table_offset;
        const uint32_t* coded = coded_.data();
        uint16_t* symbols = symbols_.data();
        size_t count = count_;
        for (int x = x0 + 1; x < x1; ++x) {
          if (coded[x] >= 16) [[unlikely]] {
            count_ = count;
            emit(offsets[x] >> kProbBits, coded[x]);
            count = count_;
            continue;
          }
          const uint16_t v = static_cast<uint16_t>((offsets[x] >> kSymbolShift) + coded[x]);
          symbols[count++] = v;
        }
        count_ = count;
        last = row[x1 - 1];
        j += static_cast<size_t>(x1 - x0);
      }
    }
  }

  // Symbol statistics in one pass after modelling, four histograms interleaved so that runs of
  // one symbol do not serialise on one counter.
  void count_symbols() {
    std::array<std::array<uint32_t, kContexts * kAlphabet>, 4> partial{};
    const uint16_t* sym = symbols_.data();
    size_t k = 0;
    for (; k + 4 <= count_; k += 4) {
      ++partial[0][sym[k]];
      ++partial[1][sym[k + 1]];
      ++partial[2][sym[k + 2]];
      ++partial[3][sym[k + 3]];
    }
    for (; k < count_; ++k) ++partial[0][sym[k]];
    for (size_t v = 0; v < counts_.size(); ++v)
      counts_[v] = partial[0][v] + partial[1][v] + partial[2][v] + partial[3][v];
  }

  // Tables: per context a 64-bit presence mask, then each used symbol's frequency as a varint.
  void write_tables(int contexts) {
    tables_.clear();
    for (int c = 0; c < contexts; ++c) {
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
  bool temporal_;
  std::string name_;
  uint8_t sequence_ = 0;
  DepthImage quantised_, prev_;
  std::vector<uint8_t> modes_, mask_;  // delta frames: per block 1 = temporal; per pixel of a row
  std::vector<uint32_t> cost_;
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
    // Any frame that fails leaves no reference: delta frames are refused until a key frame.
    const bool had_prev = has_prev_;
    has_prev_ = false;
    const Header hdr = read_header(data, "volcast");
    const int near = data[5];
    if (near > kMaxNear)
      throw Error("volcast: corrupt header (error bound " + std::to_string(near) + " mm)");
    if (data[6] > 1)
      throw Error("volcast: corrupt header (stream kind " + std::to_string(data[6]) + ")");
    const bool temporal = data[6] == 1;
    const uint8_t* p = data.data() + kDepthHeaderBytes;
    const uint8_t* end = data.data() + data.size();
    if (!hdr.key) {
      if (!temporal) throw Error("volcast: corrupt header (delta frame in a spatial stream)");
      if (!had_prev) throw Error("volcast: delta frame without a preceding key frame");
      if (prev_.width != hdr.width || prev_.height != hdr.height)
        throw Error("volcast: delta frame size differs from its key frame");
      if (prev_near_ != near)
        throw Error("volcast: delta frame error bound differs from its key frame");
      if (data[7] != static_cast<uint8_t>(prev_sequence_ + 1))
        throw Error("volcast: delta frame does not follow the last decoded frame (one was lost)");
      const size_t blocks = static_cast<size_t>((hdr.width + kBlock - 1) / kBlock) *
                            static_cast<size_t>((hdr.height + kBlock - 1) / kBlock);
      if (static_cast<size_t>(end - p) < (blocks + 7) / 8)
        throw Error("volcast: truncated stream (block modes)");
      modes_.resize(blocks);
      for (size_t b = 0; b < blocks; ++b) modes_[b] = p[b / 8] >> (b % 8) & 1;
      p += (blocks + 7) / 8;
    }
    auto get32 = [&]() -> size_t {
      if (end - p < 4) throw Error("volcast: truncated stream");
      const size_t v = size_t{p[0]} | size_t{p[1]} << 8 | size_t{p[2]} << 16 | size_t{p[3]} << 24;
      p += 4;
      return v;
    };
    const size_t table_bytes = get32();
    if (table_bytes > static_cast<size_t>(end - p)) throw Error("volcast: truncated tables");
    read_tables(p, p + table_bytes, hdr.key ? kSpatialContexts : kContexts);
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
    // The exact image (the depth, or its quantised values when near-lossless) is decoded into
    // `out` or quantised_; temporal streams keep it as the next delta frame's reference.
    const uint16_t* prev = hdr.key ? nullptr : prev_.pixels.data();
    DepthImage& exact = near > 0 ? quantised_ : out;
    if (near > 0 && (quantised_.width != hdr.width || quantised_.height != hdr.height))
      quantised_ = DepthImage(hdr.width, hdr.height);
    reconstruct(exact, rans_bytes, bits, prev);
    if (near > 0) dequantise(quantised_.pixels.data(), out.size(), near, out.pixels.data());
    if (temporal) {
      prev_ = exact;
      prev_near_ = near;
      prev_sequence_ = data[7];
      has_prev_ = true;
    }
  }

 private:
  void reconstruct(DepthImage& out, size_t rans_bytes, BitReader& bits, const uint16_t* prev) {
    const uint8_t* rp = stream_.data();
    const uint8_t* const rp_end = stream_.data() + rans_bytes;
    uint32_t s[kRansLanes];
    for (uint32_t& st : s) {
      st = uint32_t{rp[0]} | uint32_t{rp[1]} << 8 | uint32_t{rp[2]} << 16 | uint32_t{rp[3]} << 24;
      rp += 4;
      if (st < kRansLow || st >= (1u << 31)) throw Error("volcast: corrupt stream (rANS state)");
    }
    // Each symbol decodes on lane 0, then the lanes rotate, so symbol k decodes on lane k % 4.
    auto rotate = [&] { std::rotate(s, s + 1, s + kRansLanes); };
    auto value = [&](int context) -> uint32_t {
      if (!has_model_[static_cast<size_t>(context)])
        throw Error("volcast: corrupt stream (symbol without a model)");
      const uint32_t v = next_value(tables_, context, s[0], rp, bits);
      rotate();
      return v;
    };
    auto check_position = [&] {
      if (rp > rp_end) throw Error("volcast: truncated stream");
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
        if (y != model_row) {
          prepare_row(rows_, mask_, modes_, px, prev, zero_row_.data(), y, w);
          model_row = y;
        }
        if (!has_model_[kBorderContext])
          throw Error("volcast: corrupt stream (symbol without a model)");
        const int32_t first = first_prediction(mask_, px, prev, zero_row_.data(), y, x0, w, last);
        last = decode_segment(row, x0, x1, first, s, rp, bits);
        i += static_cast<size_t>(x1 - x0);
      }
    }
    check_position();
  }

  // Decodes row[x0, x1), a segment of valid pixels whose first pixel is predicted as `first`;
  // returns the last value. The lanes and the read position are copied into locals so that they
  // stay in registers (nothing outside this function sees their addresses); the tables and the
  // row model are members, all reached from `this`. W stays in a register too: the dependency
  // chain from one pixel to the next is add, max, min, add, while four independent rANS chains
  // decode ahead of it. Values are range-checked once per segment: `bad` collects every value's
  // bits, so a value outside 0..65535 sets a bit above 15 (tables allow residuals up to 2^16
  // only, so W cannot overflow within a row). A 0 inside a valid run is not an error the decoder
  // can be hurt by and is not checked.
  int32_t decode_segment(uint16_t* row, int x0, int x1, int32_t first, uint32_t* lanes,
                         const uint8_t*& read, BitReader& bits) {
    uint32_t s0 = lanes[0], s1 = lanes[1], s2 = lanes[2], s3 = lanes[3];
    const uint8_t* p = read;
    int32_t W = first + next_residual(tables_, kBorderContext * kProbScale, s0, p, bits);
    uint32_t bad = static_cast<uint32_t>(W);
    row[x0] = static_cast<uint16_t>(W);
    auto pixel = [&](uint32_t& state, int x) {
      W = rows_.predict(x, W) + next_residual(tables_, rows_.table_offset[x], state, p, bits);
      bad |= static_cast<uint32_t>(W);
      row[x] = static_cast<uint16_t>(W);
    };
    // Symbol k of the segment on lane k % 4, unrolled by the lanes so no state moves.
    int x = x0 + 1;
    for (; x + 4 <= x1; x += 4) {
      pixel(s1, x);
      pixel(s2, x + 1);
      pixel(s3, x + 2);
      pixel(s0, x + 3);
    }
    // The tail, then rotate so that the next symbol is on lane 0.
    uint32_t t[kRansLanes] = {s0, s1, s2, s3};
    int k = 1;
    for (; x < x1; ++x, ++k) pixel(t[k % kRansLanes], x);
    for (int l = 0; l < kRansLanes; ++l) lanes[l] = t[(k + l) % kRansLanes];
    read = p;
    if (bad >> 16) [[unlikely]]
      throw Error("volcast: corrupt stream (value out of range)");
    return W;
  }

  void read_tables(const uint8_t* p, const uint8_t* end, int contexts) {
    std::fill(has_model_.begin(), has_model_.end(), false);
    for (int c = 0; c < contexts; ++c) {
      if (end - p < 8) throw Error("volcast: truncated tables");
      uint64_t mask = 0;
      for (int b = 0; b < 8; ++b) mask |= uint64_t{*p++} << (8 * b);
      const size_t base = static_cast<size_t>(c) * kProbScale;
      has_model_[static_cast<size_t>(c)] = mask != 0;
      if (!mask) {
        // Never used by a valid stream; decodes as symbol 0 (residual 0) consuming nothing, so a
        // corrupt stream cannot index outside the tables.
        fill_slots(base, kProbScale, kProbScale, 0, 0);
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
        if (is_pixel_context(c) && s > kMaxResidualSymbol)
          throw Error("volcast: corrupt tables (residual symbol out of range)");
        fill_slots(
            base + start, f, f, static_cast<uint8_t>(s),
            s >= 16 ? kLongResidual : static_cast<int8_t>(unzigzag(static_cast<uint32_t>(s))));
        start += f;
      }
      if (start != kProbScale) throw Error("volcast: corrupt tables (frequencies do not sum up)");
    }
  }

  // Slots [first, first + count) of one symbol of frequency `freq`.
  void fill_slots(size_t first, uint32_t count, uint32_t freq, uint8_t symbol, int8_t residual) {
    for (uint32_t o = 0; o < count; ++o) {
      tables_.freq[first + o] = static_cast<uint16_t>(freq);
      tables_.offset[first + o] = static_cast<uint16_t>(o);
    }
    std::fill_n(tables_.symbol.data() + first, count, symbol);
    std::fill_n(tables_.residual.data() + first, count, residual);
  }

  DecodeTables tables_{};
  std::array<bool, kContexts> has_model_{};
  std::vector<uint8_t> stream_;
  std::vector<uint16_t> zero_row_;
  DepthImage quantised_;  // near-lossless: the decoded quantised image
  DepthImage prev_;       // temporal streams: the last frame's exact image
  int prev_near_ = 0;
  uint8_t prev_sequence_ = 0;
  bool has_prev_ = false;
  std::vector<uint8_t> modes_, mask_;  // delta frames: block modes; per pixel of a row
  RowModel rows_;  // beside the tables, both reached from `this` (few registers in the hot loop)
};

}  // namespace

std::unique_ptr<DepthEncoder> make_volcast_encoder(int near_mm, bool temporal) {
  return std::make_unique<VolcastEncoder>(near_mm, temporal);
}
std::unique_ptr<DepthDecoder> make_volcast_decoder() {
  return std::make_unique<VolcastDecoder>();
}

}  // namespace volcast::detail
