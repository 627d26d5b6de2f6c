// General-purpose lossless compressors (Zstd, LZ4) on depth after a transform that makes depth
// look like what they are good at: each sample becomes its difference to the left neighbour (the
// pixel above for a row's first), modulo 2^16 and zigzag-mapped, and the low and high bytes of all
// differences are stored as two planes. Smooth surfaces give small differences, so the high plane
// is almost all zero and invalid runs are long zero runs. Exact for every uint16 value.
#include <lz4.h>
#include <zstd.h>

#include "builtin_codecs.hpp"
#include "volcast/codec/detail/frame_header.hpp"

namespace volcast::detail {
namespace {

void to_planes(const DepthImage& d, uint8_t* planes) {
  const size_t n = d.size();
  const int w = d.width;
  const uint16_t* px = d.pixels.data();
  for (size_t i = 0; i < n; ++i) {
    const uint16_t reference =
        i == 0 ? 0 : (i % static_cast<size_t>(w) == 0 ? px[i - w] : px[i - 1]);
    // Zigzag of the 16-bit difference: small differences of either sign have a zero high byte.
    const auto delta = static_cast<int16_t>(static_cast<uint16_t>(px[i] - reference));
    const auto zz = static_cast<uint16_t>((static_cast<uint16_t>(delta) << 1) ^
                                          static_cast<uint16_t>(delta >> 15));
    planes[i] = static_cast<uint8_t>(zz);
    planes[n + i] = static_cast<uint8_t>(zz >> 8);
  }
}

void from_planes(const uint8_t* planes, DepthImage& d) {
  const size_t n = d.size();
  const int w = d.width;
  uint16_t* px = d.pixels.data();
  for (size_t i = 0; i < n; ++i) {
    const uint16_t reference =
        i == 0 ? 0 : (i % static_cast<size_t>(w) == 0 ? px[i - w] : px[i - 1]);
    const auto zz = static_cast<uint16_t>(planes[i] | planes[n + i] << 8);
    const auto delta = static_cast<uint16_t>((zz >> 1) ^ static_cast<uint16_t>(-(zz & 1)));
    px[i] = static_cast<uint16_t>(reference + delta);
  }
}

class BytePlaneEncoder final : public DepthEncoder {
 public:
  explicit BytePlaneEncoder(CodecId id) : id_(id) {
    if (id_ == kZstd) cctx_ = ZSTD_createCCtx();
  }
  ~BytePlaneEncoder() override { ZSTD_freeCCtx(cctx_); }

  bool encode(const DepthImage& depth, bool, std::vector<uint8_t>& out) override {
    check_size(depth);
    const size_t raw = depth.size() * 2;
    planes_.resize(raw);
    to_planes(depth, planes_.data());
    const size_t bound = id_ == kZstd
                             ? ZSTD_compressBound(raw)
                             : static_cast<size_t>(LZ4_compressBound(static_cast<int>(raw)));
    out.resize(kDepthHeaderBytes + bound);
    write_header(out.data(), id_, true, depth.width, depth.height);
    size_t written;
    if (id_ == kZstd) {
      written =
          ZSTD_compressCCtx(cctx_, out.data() + kDepthHeaderBytes, bound, planes_.data(), raw, 1);
      if (ZSTD_isError(written)) throw Error(std::string("zstd: ") + ZSTD_getErrorName(written));
    } else {
      const int n = LZ4_compress_default(reinterpret_cast<const char*>(planes_.data()),
                                         reinterpret_cast<char*>(out.data() + kDepthHeaderBytes),
                                         static_cast<int>(raw), static_cast<int>(bound));
      if (n <= 0) throw Error("lz4: compression failed");
      written = static_cast<size_t>(n);
    }
    out.resize(kDepthHeaderBytes + written);
    return true;
  }
  std::string_view name() const override { return codec_label(id_); }

 private:
  CodecId id_;
  ZSTD_CCtx* cctx_ = nullptr;
  std::vector<uint8_t> planes_;
};

class BytePlaneDecoder final : public DepthDecoder {
 public:
  explicit BytePlaneDecoder(CodecId id) : id_(id) {
    if (id_ == kZstd) dctx_ = ZSTD_createDCtx();
  }
  ~BytePlaneDecoder() override { ZSTD_freeDCtx(dctx_); }

  void decode(std::span<const uint8_t> data, DepthImage& out) override {
    const char* label = codec_label(id_);
    const Header h = read_header(data, label);
    const size_t raw = h.pixels() * 2;
    planes_.resize(raw);
    const auto body = data.subspan(kDepthHeaderBytes);
    size_t got;
    if (id_ == kZstd) {
      got = ZSTD_decompressDCtx(dctx_, planes_.data(), raw, body.data(), body.size());
      if (ZSTD_isError(got))
        throw Error(std::string("zstd: corrupt stream (") + ZSTD_getErrorName(got) + ")");
    } else {
      const int n = LZ4_decompress_safe(reinterpret_cast<const char*>(body.data()),
                                        reinterpret_cast<char*>(planes_.data()),
                                        static_cast<int>(body.size()), static_cast<int>(raw));
      if (n < 0) throw Error("lz4: corrupt stream");
      got = static_cast<size_t>(n);
    }
    if (got != raw)
      throw Error(std::string(label) + ": corrupt stream (decoded size differs from the header)");
    if (out.width != h.width || out.height != h.height) out = DepthImage(h.width, h.height);
    from_planes(planes_.data(), out);
  }

 private:
  CodecId id_;
  ZSTD_DCtx* dctx_ = nullptr;
  std::vector<uint8_t> planes_;
};

}  // namespace

std::unique_ptr<DepthEncoder> make_byte_plane_encoder(CodecId id) {
  return std::make_unique<BytePlaneEncoder>(id);
}
std::unique_ptr<DepthDecoder> make_byte_plane_decoder(CodecId id) {
  return std::make_unique<BytePlaneDecoder>(id);
}

}  // namespace volcast::detail
