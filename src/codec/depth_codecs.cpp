#include <algorithm>
#include <cstdlib>
#include <cstring>

#include "builtin_codecs.hpp"
#include "nibble_coding.hpp"
#include "volcast/codec/depth_codec.hpp"
#include "volcast/codec/detail/frame_header.hpp"
#include "volcast/core/error.hpp"

namespace volcast {
namespace {

using detail::check_size;
using detail::Header;
using detail::kRaw;
using detail::kRvl;
using detail::kTrvl;
using detail::NibbleReader;
using detail::NibbleWriter;
using detail::read_header;
using detail::write_header;

// RVL body of a frame: alternating (zero count, nonzero count, zigzag deltas of the nonzero
// values).
size_t rvl_encode_body(const uint16_t* px, size_t n, uint8_t* out) {
  NibbleWriter w(out);
  int32_t previous = 0;
  size_t i = 0;
  while (i < n) {
    size_t zeros = 0;
    while (i < n && px[i] == 0) ++zeros, ++i;
    w.put_vle(static_cast<uint32_t>(zeros));
    size_t start = i;
    while (i < n && px[i] != 0) ++i;
    w.put_vle(static_cast<uint32_t>(i - start));
    for (size_t j = start; j < i; ++j) {
      const int32_t v = px[j];
      w.put_vle(detail::zigzag(v - previous));
      previous = v;
    }
  }
  return w.finish();
}

void rvl_decode_body(std::span<const uint8_t> body, uint16_t* px, size_t n, const char* codec) {
  NibbleReader r(body.data(), body.size(), codec);
  int32_t previous = 0;
  size_t i = 0;
  while (i < n) {
    const uint32_t zeros = r.get_vle();
    if (zeros > n - i)
      throw Error(std::string(codec) + ": corrupt stream (zero run past the image)");
    std::fill(px + i, px + i + zeros, uint16_t{0});
    i += zeros;
    const uint32_t nonzeros = r.get_vle();
    if (nonzeros > n - i) throw Error(std::string(codec) + ": corrupt stream (run past the image)");
    for (uint32_t j = 0; j < nonzeros; ++j) {
      const int64_t v = int64_t{previous} + detail::unzigzag(r.get_vle());
      if (v <= 0 || v > 65535)
        throw Error(std::string(codec) + ": corrupt stream (value out of range)");
      px[i++] = static_cast<uint16_t>(v);
      previous = static_cast<int32_t>(v);
    }
    if (zeros == 0 && nonzeros == 0 && i < n)
      throw Error(std::string(codec) + ": corrupt stream (empty run)");
  }
}

class RawEncoder final : public DepthEncoder {
 public:
  bool encode(const DepthImage& depth, bool, std::vector<uint8_t>& out) override {
    check_size(depth);
    out.resize(kDepthHeaderBytes + depth.size() * 2);
    write_header(out.data(), kRaw, true, depth.width, depth.height);
    uint8_t* p = out.data() + kDepthHeaderBytes;
    for (uint16_t v : depth.pixels) *p++ = uint8_t(v), *p++ = uint8_t(v >> 8);
    return true;
  }
  std::string_view name() const override { return "raw"; }
};

class RawDecoder final : public DepthDecoder {
 public:
  void decode(std::span<const uint8_t> data, DepthImage& out) override {
    const Header h = read_header(data, "raw");
    const size_t n = static_cast<size_t>(h.width) * h.height;
    if (data.size() != kDepthHeaderBytes + n * 2)
      throw Error("raw: body size does not match the header");
    if (out.width != h.width || out.height != h.height) out = DepthImage(h.width, h.height);
    const uint8_t* p = data.data() + kDepthHeaderBytes;
    for (size_t i = 0; i < n; ++i)
      out.pixels[i] = static_cast<uint16_t>(p[2 * i] | p[2 * i + 1] << 8);
  }
};

class RvlEncoder final : public DepthEncoder {
 public:
  bool encode(const DepthImage& depth, bool, std::vector<uint8_t>& out) override {
    check_size(depth);
    out.resize(kDepthHeaderBytes + detail::max_body_bytes(depth.size()));
    write_header(out.data(), kRvl, true, depth.width, depth.height);
    out.resize(kDepthHeaderBytes +
               rvl_encode_body(depth.pixels.data(), depth.size(), out.data() + kDepthHeaderBytes));
    return true;
  }
  std::string_view name() const override { return "rvl"; }
};

class RvlDecoder final : public DepthDecoder {
 public:
  void decode(std::span<const uint8_t> data, DepthImage& out) override {
    const Header h = read_header(data, "rvl");
    if (out.width != h.width || out.height != h.height) out = DepthImage(h.width, h.height);
    rvl_decode_body(data.subspan(kDepthHeaderBytes), out.pixels.data(), out.size(), "rvl");
  }
};

// Temporal RVL. `state_` is the frame the decoder holds after the last emitted frame.
class TrvlEncoder final : public DepthEncoder {
 public:
  explicit TrvlEncoder(const TrvlParams& p) : params_(p) {}
  bool encode(const DepthImage& depth, bool key_frame, std::vector<uint8_t>& out) override {
    check_size(depth);
    const size_t n = depth.size();
    const bool key = key_frame || state_.width != depth.width || state_.height != depth.height;
    out.resize(kDepthHeaderBytes + detail::max_body_bytes(n));
    write_header(out.data(), kTrvl, key, depth.width, depth.height);
    uint8_t* body = out.data() + kDepthHeaderBytes;
    if (key) {
      state_ = depth;
      invalid_frames_.assign(n, 0);
      out.resize(kDepthHeaderBytes + rvl_encode_body(depth.pixels.data(), n, body));
      return true;
    }
    NibbleWriter w(body);
    const uint16_t* in = depth.pixels.data();
    uint16_t* s = state_.pixels.data();
    size_t i = 0;
    while (i < n) {
      size_t zeros = 0;
      while (i < n && next_value(i, in[i]) == s[i]) {
        invalid_frames_[i] = in[i] == 0 ? static_cast<uint16_t>(invalid_frames_[i] + 1) : 0;
        ++zeros, ++i;
      }
      w.put_vle(static_cast<uint32_t>(zeros));
      const size_t start = i;
      size_t end = i;
      // Find the run of changed pixels, then code their differences.
      while (end < n && next_value(end, in[end]) != s[end]) ++end;
      w.put_vle(static_cast<uint32_t>(end - start));
      for (; i < end; ++i) {
        const uint16_t v = next_value(i, in[i]);
        w.put_vle(detail::zigzag(int32_t{v} - int32_t{s[i]}));
        s[i] = v;
        invalid_frames_[i] = in[i] == 0 ? static_cast<uint16_t>(invalid_frames_[i] + 1) : 0;
      }
    }
    out.resize(kDepthHeaderBytes + w.finish());
    return false;
  }
  std::string_view name() const override { return "trvl"; }

 private:
  // The value the decoder should hold for pixel i given the new measurement (Jun & Bailenson's
  // pixel update; with both thresholds 0 it is `value` itself).
  uint16_t next_value(size_t i, uint16_t value) const {
    const uint16_t held = state_.pixels[i];
    if (value == 0) {
      return (held != 0 && invalid_frames_[i] < params_.invalidation_frames) ? held : 0;
    }
    if (held != 0 && std::abs(int{value} - int{held}) <= params_.change_threshold_mm) return held;
    return value;
  }
  TrvlParams params_;
  DepthImage state_;
  std::vector<uint16_t> invalid_frames_;
};

class TrvlDecoder final : public DepthDecoder {
 public:
  void decode(std::span<const uint8_t> data, DepthImage& out) override {
    const Header h = read_header(data, "trvl");
    const auto body = data.subspan(kDepthHeaderBytes);
    if (h.key) {
      DepthImage next(h.width, h.height);
      rvl_decode_body(body, next.pixels.data(), next.size(), "trvl");
      state_ = std::move(next);
    } else {
      if (state_.width == 0) throw Error("trvl: delta frame without a preceding key frame");
      if (state_.width != h.width || state_.height != h.height)
        throw Error("trvl: delta frame size differs from its key frame");
      apply_delta(body);
    }
    out = state_;
  }

 private:
  void apply_delta(std::span<const uint8_t> body) {
    // Decode into a scratch copy so a corrupt frame leaves the held state untouched.
    scratch_ = state_;
    NibbleReader r(body.data(), body.size(), "trvl");
    uint16_t* s = scratch_.pixels.data();
    const size_t n = scratch_.size();
    size_t i = 0;
    while (i < n) {
      const uint32_t same = r.get_vle();
      if (same > n - i) throw Error("trvl: corrupt stream (run past the image)");
      i += same;
      const uint32_t changed = r.get_vle();
      if (changed > n - i) throw Error("trvl: corrupt stream (run past the image)");
      for (uint32_t j = 0; j < changed; ++j, ++i) {
        const int64_t v = int64_t{s[i]} + detail::unzigzag(r.get_vle());
        if (v < 0 || v > 65535) throw Error("trvl: corrupt stream (value out of range)");
        s[i] = static_cast<uint16_t>(v);
      }
      if (same == 0 && changed == 0 && i < n) throw Error("trvl: corrupt stream (empty run)");
    }
    std::swap(state_, scratch_);
  }
  DepthImage state_, scratch_;
};

}  // namespace

std::unique_ptr<DepthEncoder> make_trvl_encoder(const TrvlParams& params) {
  return std::make_unique<TrvlEncoder>(params);
}

namespace detail {
std::unique_ptr<DepthEncoder> make_raw_depth_encoder() {
  return std::make_unique<RawEncoder>();
}
std::unique_ptr<DepthDecoder> make_raw_depth_decoder() {
  return std::make_unique<RawDecoder>();
}
std::unique_ptr<DepthEncoder> make_rvl_encoder() {
  return std::make_unique<RvlEncoder>();
}
std::unique_ptr<DepthDecoder> make_rvl_decoder() {
  return std::make_unique<RvlDecoder>();
}
std::unique_ptr<DepthDecoder> make_trvl_decoder() {
  return std::make_unique<TrvlDecoder>();
}
}  // namespace detail

bool depth_frame_is_key(std::span<const uint8_t> data) {
  if (data.size() < kDepthHeaderBytes || data[0] != 'V' || data[1] != 'D')
    throw Error("not a Volcast depth frame");
  return (data[4] & detail::kKeyFlag) != 0;
}

}  // namespace volcast
