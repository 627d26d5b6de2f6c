#include <cstring>

#include "builtin_codecs.hpp"
#include "volcast/codec/color_codec.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/jpeg.hpp"

namespace volcast {
namespace {

constexpr size_t kHeader = 12;

}  // namespace

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
    out.resize(kHeader + image.bgra.size());
    const uint8_t header[kHeader] = {'V',
                                     'C',
                                     1,
                                     0,
                                     0,
                                     0,
                                     0,
                                     0,
                                     uint8_t(image.width),
                                     uint8_t(image.width >> 8),
                                     uint8_t(image.height),
                                     uint8_t(image.height >> 8)};
    std::memcpy(out.data(), header, kHeader);
    if (!image.bgra.empty())
      std::memcpy(out.data() + kHeader, image.bgra.data(), image.bgra.size());
    return true;
  }
  std::string_view name() const override { return "raw"; }
};

class RawDecoder final : public ColorDecoder {
 public:
  void decode(std::span<const uint8_t> d, ColorImage& out) override {
    if (d.size() < kHeader || d[0] != 'V' || d[1] != 'C' || d[2] != 1)
      throw Error("raw color: not a Volcast raw color frame");
    const int w = d[8] | d[9] << 8, h = d[10] | d[11] << 8;
    if (d.size() != kHeader + static_cast<size_t>(w) * h * 4)
      throw Error("raw color: body size does not match the header");
    if (out.width != w || out.height != h) out = ColorImage(w, h);
    if (!out.bgra.empty()) std::memcpy(out.bgra.data(), d.data() + kHeader, out.bgra.size());
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
