#include <cstring>

#include "builtin_codecs.hpp"
#include "volcast/codec/color_codec.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/jpeg.hpp"

namespace volcast {
namespace {}  // namespace

void ColorEncoder::set_quality(int quality) {
  if (quality < 1 || quality > 100)
    throw Error("color quality " + std::to_string(quality) + " is outside 1..100");
}

namespace {

class JpegEncoder final : public ColorEncoder {
 public:
  bool encode(const ColorImage& image, bool, std::vector<uint8_t>& out) override {
    encode_jpeg(image, quality_, out);
    return true;
  }
  std::string_view name() const override { return "jpeg"; }
  void set_quality(int quality) override {
    ColorEncoder::set_quality(quality);  // checks the range
    quality_ = quality;
  }

 private:
  int quality_ = 90;
};

class JpegDecoder final : public ColorDecoder {
 public:
  void decode(std::span<const uint8_t> data, ColorImage& out) override { decode_jpeg(data, out); }
};

class RawEncoder final : public ColorEncoder {
 public:
  bool encode(const ColorImage& image, bool, std::vector<uint8_t>& out) override {
    out.resize(kColorHeaderBytes + image.bgra.size());
    write_color_header({kColorCodecRaw, false, image.width, image.height}, out);
    if (!image.bgra.empty())
      std::memcpy(out.data() + kColorHeaderBytes, image.bgra.data(), image.bgra.size());
    return true;
  }
  std::string_view name() const override { return "raw"; }
};

class RawDecoder final : public ColorDecoder {
 public:
  void decode(std::span<const uint8_t> d, ColorImage& out) override {
    const std::optional<ColorHeader> header = read_color_header(d);
    if (!header) throw Error("raw color: not a Volcast raw color frame");
    const int w = header->width, h = header->height;
    if (d.size() != kColorHeaderBytes + static_cast<size_t>(w) * h * 4)
      throw Error("raw color: body size does not match the header");
    if (out.width != w || out.height != h) out = ColorImage(w, h);
    if (!out.bgra.empty())
      std::memcpy(out.bgra.data(), d.data() + kColorHeaderBytes, out.bgra.size());
  }
};

class NoneEncoder final : public ColorEncoder {
 public:
  bool encode(const ColorImage&, bool, std::vector<uint8_t>& out) override {
    out.clear();
    return true;
  }
  std::string_view name() const override { return "none"; }
};

class NoneDecoder final : public ColorDecoder {
 public:
  void decode(std::span<const uint8_t>, ColorImage& out) override { out = ColorImage(); }
};

}  // namespace

void write_color_header(const ColorHeader& header, std::span<uint8_t> out) {
  if (out.size() < kColorHeaderBytes) throw Error("color header: fewer than 12 bytes to write to");
  const auto w = static_cast<uint16_t>(header.width), h = static_cast<uint16_t>(header.height);
  const uint8_t bytes[kColorHeaderBytes] = {'V',
                                            'C',
                                            1,
                                            header.codec_id,
                                            uint8_t(header.key ? 1 : 0),
                                            0,
                                            0,
                                            0,
                                            uint8_t(w),
                                            uint8_t(w >> 8),
                                            uint8_t(h),
                                            uint8_t(h >> 8)};
  std::memcpy(out.data(), bytes, kColorHeaderBytes);
}

std::optional<ColorHeader> read_color_header(std::span<const uint8_t> f) {
  if (f.size() < kColorHeaderBytes || f[0] != 'V' || f[1] != 'C' || f[2] != 1) return std::nullopt;
  return ColorHeader{f[3], (f[4] & 1) != 0, f[8] | f[9] << 8, f[10] | f[11] << 8};
}

namespace detail {
std::unique_ptr<ColorEncoder> make_jpeg_color_encoder() {
  return std::make_unique<JpegEncoder>();
}
std::unique_ptr<ColorDecoder> make_jpeg_color_decoder() {
  return std::make_unique<JpegDecoder>();
}
std::unique_ptr<ColorEncoder> make_raw_color_encoder() {
  return std::make_unique<RawEncoder>();
}
std::unique_ptr<ColorDecoder> make_raw_color_decoder() {
  return std::make_unique<RawDecoder>();
}
std::unique_ptr<ColorEncoder> make_none_color_encoder() {
  return std::make_unique<NoneEncoder>();
}
std::unique_ptr<ColorDecoder> make_none_color_decoder() {
  return std::make_unique<NoneDecoder>();
}
}  // namespace detail

}  // namespace volcast
