#include "volcast/core/image_io.hpp"

#include <png.h>

#include <cstdio>
#include <cstring>
#include <memory>
#include <string>

#include "volcast/core/error.hpp"

namespace volcast {
namespace {

struct FileCloser {
  void operator()(FILE* f) const { std::fclose(f); }
};
using File = std::unique_ptr<FILE, FileCloser>;

File open_file(const std::filesystem::path& path, const char* mode) {
  File f(std::fopen(path.c_str(), mode));
  if (!f) throw Error("cannot open '" + path.string() + "'");
  return f;
}

[[noreturn]] void png_error_fn(png_structp png, png_const_charp msg) {
  auto* text = static_cast<std::string*>(png_get_error_ptr(png));
  *text = msg;
  png_longjmp(png, 1);
}
void png_warning_fn(png_structp, png_const_charp) {}

// Decoded PNG rows of one bit depth and channel count, as libpng delivers them after transforms.
struct RawPng {
  int width = 0, height = 0, channels = 0, bit_depth = 0;
  std::vector<uint8_t> data;
};

// libpng's read structures, freed however read_png leaves (return, throw, or longjmp then throw).
struct PngReadGuard {
  png_structp png = nullptr;
  png_infop info = nullptr;
  ~PngReadGuard() {
    if (png) png_destroy_read_struct(&png, info ? &info : nullptr, nullptr);
  }
};

// What read_png fills in. On the heap, and reached through a pointer set before setjmp: objects
// changed between setjmp and a longjmp back must not be automatic variables of that frame.
struct PngReadState {
  RawPng out;
  std::vector<png_bytep> rows;
  std::string error;
};

// Reads any PNG; for 16-bit data the samples are converted to host byte order. `want16` asks to
// keep 16 bits (depth); otherwise 16-bit color is stripped to 8 bits and palettes are expanded.
// The size in the header is checked against kMaxImageSide before any pixel memory is allocated.
RawPng read_png(const std::filesystem::path& path, bool want16) {
  File f = open_file(path, "rb");
  uint8_t sig[8];
  const size_t got = std::fread(sig, 1, 8, f.get());
  if (got != 8 && got > 0 && png_sig_cmp(sig, 0, got) == 0)
    throw Error("truncated PNG '" + path.string() + "': the file ends inside the signature");
  if (got != 8 || png_sig_cmp(sig, 0, 8) != 0)
    throw Error("'" + path.string() + "' is not a PNG file");
  const auto state = std::make_unique<PngReadState>();
  PngReadGuard g;
  g.png =
      png_create_read_struct(PNG_LIBPNG_VER_STRING, &state->error, png_error_fn, png_warning_fn);
  if (!g.png) throw Error("cannot read '" + path.string() + "': out of memory");
  g.info = png_create_info_struct(g.png);
  if (!g.info) throw Error("cannot read '" + path.string() + "': out of memory");
  if (setjmp(png_jmpbuf(g.png))) {
    if (std::feof(f.get()))
      throw Error("truncated PNG '" + path.string() + "': the file ends early (" + state->error +
                  ")");
    throw Error("corrupt PNG '" + path.string() + "': " + state->error);
  }
  png_structp png = g.png;
  png_infop info = g.info;
  // libpng's own limit would refuse a huge header without saying the size; ours below does.
  png_set_user_limits(png, 0x7fffffff, 0x7fffffff);
  png_init_io(png, f.get());
  png_set_sig_bytes(png, 8);
  png_read_info(png, info);
  const png_uint_32 header_w = png_get_image_width(png, info);
  const png_uint_32 header_h = png_get_image_height(png, info);
  if (header_w > static_cast<png_uint_32>(kMaxImageSide) ||
      header_h > static_cast<png_uint_32>(kMaxImageSide))
    throw Error("PNG '" + path.string() + "' claims " + std::to_string(header_w) + "x" +
                std::to_string(header_h) + " pixels, more than the " +
                std::to_string(kMaxImageSide) + " per side accepted");
  const int color_type = png_get_color_type(png, info);
  int bit_depth = png_get_bit_depth(png, info);
  if (color_type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
  if (color_type == PNG_COLOR_TYPE_GRAY && bit_depth < 8) png_set_expand_gray_1_2_4_to_8(png);
  if (bit_depth == 16) {
    if (want16) {
      png_set_swap(png);  // PNG stores 16-bit big-endian; deliver host (little-endian) order.
    } else {
      png_set_strip_16(png);
    }
  }
  png_read_update_info(png, info);
  RawPng& out = state->out;
  out.width = static_cast<int>(png_get_image_width(png, info));
  out.height = static_cast<int>(png_get_image_height(png, info));
  out.channels = png_get_channels(png, info);
  out.bit_depth = png_get_bit_depth(png, info);
  const size_t row_bytes = png_get_rowbytes(png, info);
  out.data.resize(row_bytes * static_cast<size_t>(out.height));
  state->rows.resize(static_cast<size_t>(out.height));
  for (int y = 0; y < out.height; ++y)
    state->rows[static_cast<size_t>(y)] = &out.data[row_bytes * static_cast<size_t>(y)];
  png_read_image(png, state->rows.data());
  png_read_end(png, nullptr);
  return std::move(state->out);
}

void write_png(const std::filesystem::path& path, int width, int height, int color_type,
               int bit_depth, const uint8_t* data, size_t row_bytes, bool swap16) {
  File f = open_file(path, "wb");
  std::string err;
  png_structp png =
      png_create_write_struct(PNG_LIBPNG_VER_STRING, &err, png_error_fn, png_warning_fn);
  png_infop info = png_create_info_struct(png);
  std::vector<png_bytep> rows(static_cast<size_t>(height));
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    throw Error("cannot write PNG '" + path.string() + "': " + err);
  }
  png_init_io(png, f.get());
  png_set_compression_level(png, 1);  // fast: saved frames and renders are written live
  png_set_IHDR(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height),
               bit_depth, color_type, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  if (swap16) png_set_swap(png);
  for (int y = 0; y < height; ++y)
    rows[static_cast<size_t>(y)] = const_cast<uint8_t*>(data + row_bytes * static_cast<size_t>(y));
  png_write_image(png, rows.data());
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
}

}  // namespace

DepthImage read_depth_png(const std::filesystem::path& path) {
  RawPng raw = read_png(path, true);
  if (raw.bit_depth != 16 || raw.channels != 1)
    throw Error("depth PNG '" + path.string() + "' must be 16-bit grayscale (got " +
                std::to_string(raw.bit_depth) + "-bit, " + std::to_string(raw.channels) +
                " channel(s))");
  DepthImage depth(raw.width, raw.height);
  std::memcpy(depth.pixels.data(), raw.data.data(), depth.size() * 2);
  return depth;
}

void write_depth_png(const std::filesystem::path& path, const DepthImage& depth) {
  write_png(path, depth.width, depth.height, PNG_COLOR_TYPE_GRAY, 16,
            reinterpret_cast<const uint8_t*>(depth.pixels.data()),
            static_cast<size_t>(depth.width) * 2, true);
}

ColorImage read_color_png(const std::filesystem::path& path) {
  RawPng raw = read_png(path, false);
  ColorImage color(raw.width, raw.height);
  const size_t n = static_cast<size_t>(raw.width) * raw.height;
  for (size_t i = 0; i < n; ++i) {
    const uint8_t* s = &raw.data[i * raw.channels];
    uint8_t* d = &color.bgra[i * 4];
    if (raw.channels >= 3) {
      d[0] = s[2], d[1] = s[1], d[2] = s[0];
    } else {
      d[0] = d[1] = d[2] = s[0];
    }
    d[3] = (raw.channels == 4) ? s[3] : (raw.channels == 2 ? s[1] : 255);
  }
  return color;
}

void write_color_png(const std::filesystem::path& path, const ColorImage& color) {
  std::vector<uint8_t> rgba(color.bgra.size());
  for (size_t i = 0; i < rgba.size(); i += 4) {
    rgba[i] = color.bgra[i + 2];
    rgba[i + 1] = color.bgra[i + 1];
    rgba[i + 2] = color.bgra[i];
    rgba[i + 3] = color.bgra[i + 3];
  }
  write_png(path, color.width, color.height, PNG_COLOR_TYPE_RGBA, 8, rgba.data(),
            static_cast<size_t>(color.width) * 4, false);
}

}  // namespace volcast
