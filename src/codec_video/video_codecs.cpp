// Lossy video codecs through libavcodec: depth as H.264 (x264, 10-bit) or HEVC (x265, 12-bit),
// and H.264 color (x264, 8-bit 4:2:0).
//
// Depth mapping: valid depth is mapped linearly onto the codec's full code range over the
// [near, far] mm range of the last key frame's valid values (sent with every frame), so one code
// step is (far - near) / (2^bits - 1) mm; invalid pixels take their left neighbour's code so that
// holes add no edges to code. Which pixels are valid is sent losslessly beside the video (run
// lengths, Zstd), so the valid mask decodes exactly and only valid depth carries the video's
// error. The wire formats are documented in volcast/codec_video/video_codecs.hpp.
#include <zstd.h>

#include <algorithm>
#include <cmath>
#include <mutex>

#include "video.hpp"
#include "volcast/codec/color_codec.hpp"
#include "volcast/codec/detail/frame_header.hpp"
#include "volcast/codec/registry.hpp"
#include "volcast/codec_video/video_codecs.hpp"

extern "C" {
#include <libswscale/swscale.h>
}

namespace volcast::detail {
namespace {

constexpr int kDepthCrf = 12;  // depth detail matters more than color's; see the bench's errors
constexpr int kColorCrf = 23;  // x264's default

void put_varint(std::vector<uint8_t>& out, uint32_t v) {
  for (; v >= 0x80; v >>= 7) out.push_back(static_cast<uint8_t>(v | 0x80));
  out.push_back(static_cast<uint8_t>(v));
}

uint32_t get_varint(const uint8_t*& p, const uint8_t* end, const char* label) {
  uint32_t v = 0;
  for (int shift = 0;; shift += 7) {
    if (p == end || shift > 28) throw Error(std::string(label) + ": corrupt valid mask");
    const uint8_t b = *p++;
    v |= uint32_t{b & 0x7fu} << shift;
    if (!(b & 0x80)) return v;
  }
}

const char* label_of(CodecId id) {
  return id == kH264 ? "h264" : "hevc";
}

class VideoDepthEncoder final : public DepthEncoder {
 public:
  explicit VideoDepthEncoder(CodecId id)
      : id_(id),
        bits_(id == kH264 ? 10 : 12),
        video_(id == kH264 ? "libx264" : "libx265", label_of(id),
               id == kH264 ? AV_PIX_FMT_YUV420P10LE : AV_PIX_FMT_YUV420P12LE, kDepthCrf) {}

  bool encode(const DepthImage& depth, bool key_frame, std::vector<uint8_t>& out) override {
    check_size(depth);
    const int w = depth.width, h = depth.height;
    const bool resized = w != width_ || h != height_;
    key_frame = key_frame || resized;
    width_ = w, height_ = h;
    if (key_frame) choose_range(depth);
    // The valid mask as alternating run lengths (invalid first), Zstd-compressed.
    runs_.clear();
    const uint16_t* px = depth.pixels.data();
    for (size_t i = 0, n = depth.size(); i < n;) {
      size_t start = i;
      while (i < n && px[i] == 0) ++i;
      put_varint(runs_, static_cast<uint32_t>(i - start));
      start = i;
      while (i < n && px[i] != 0) ++i;
      put_varint(runs_, static_cast<uint32_t>(i - start));
    }
    mask_.resize(ZSTD_compressBound(runs_.size()));
    const size_t mask_bytes =
        ZSTD_compress(mask_.data(), mask_.size(), runs_.data(), runs_.size(), 1);
    if (ZSTD_isError(mask_bytes)) throw Error(std::string(label_of(id_)) + ": Zstd failed");

    // Even frame size for 4:2:0, at least x265's 16x16; the padding repeats the last column
    // and row.
    const int fw = std::max(16, (w + 1) & ~1), fh = std::max(16, (h + 1) & ~1);
    AVFrame* f = video_.frame(fw, fh);
    const int32_t max_code = (1 << bits_) - 1;
    const double scale = static_cast<double>(max_code) / (far_ - near_);
    for (int y = 0; y < fh; ++y) {
      const uint16_t* row = px + static_cast<size_t>(std::min(y, h - 1)) * w;
      auto* dst =
          reinterpret_cast<uint16_t*>(f->data[0] + static_cast<ptrdiff_t>(y) * f->linesize[0]);
      uint16_t code = 0;
      for (int x = 0; x < fw; ++x) {
        const int32_t d = row[std::min(x, w - 1)];
        if (d) {
          const double c = std::round((std::clamp(d, near_, far_) - near_) * scale);
          code = static_cast<uint16_t>(std::clamp(static_cast<int32_t>(c), 0, max_code));
        }
        dst[x] = code;
      }
    }
    const uint16_t mid = static_cast<uint16_t>(1 << (bits_ - 1));
    for (int plane = 1; plane < 3; ++plane)
      for (int y = 0; y < fh / 2; ++y) {
        auto* dst = reinterpret_cast<uint16_t*>(f->data[plane] +
                                                static_cast<ptrdiff_t>(y) * f->linesize[plane]);
        std::fill(dst, dst + fw / 2, mid);
      }
    packet_.clear();
    const bool key = video_.encode(key_frame, packet_);

    out.resize(kDepthHeaderBytes + 12 + mask_bytes + packet_.size());
    write_header(out.data(), id_, key, w, h);
    out[5] = static_cast<uint8_t>(bits_);
    uint8_t* p = out.data() + kDepthHeaderBytes;
    *p++ = static_cast<uint8_t>(near_), *p++ = static_cast<uint8_t>(near_ >> 8);
    *p++ = static_cast<uint8_t>(far_), *p++ = static_cast<uint8_t>(far_ >> 8);
    for (int b = 0; b < 4; ++b) *p++ = static_cast<uint8_t>(mask_bytes >> (8 * b));
    for (int b = 0; b < 4; ++b) *p++ = static_cast<uint8_t>(packet_.size() >> (8 * b));
    p = std::copy(mask_.begin(), mask_.begin() + static_cast<ptrdiff_t>(mask_bytes), p);
    std::copy(packet_.begin(), packet_.end(), p);
    return key;
  }
  std::string_view name() const override { return label_of(id_); }

 private:
  // The mapped range: the key frame's valid depth, with a margin for what moves until the next.
  void choose_range(const DepthImage& depth) {
    int32_t lo = 65535, hi = 0;
    for (const uint16_t d : depth.pixels)
      if (d) lo = std::min<int32_t>(lo, d), hi = std::max<int32_t>(hi, d);
    if (hi == 0) lo = 1, hi = 65535;
    near_ = std::max(1, lo - 100);
    far_ = std::min(65535, std::max(hi + 100, near_ + 1));
  }

  CodecId id_;
  int bits_;
  VideoEncoder video_;
  int width_ = 0, height_ = 0;
  int32_t near_ = 1, far_ = 65535;
  std::vector<uint8_t> runs_, mask_, packet_;
};

class VideoDepthDecoder final : public DepthDecoder {
 public:
  explicit VideoDepthDecoder(CodecId id)
      : id_(id), video_(id == kH264 ? AV_CODEC_ID_H264 : AV_CODEC_ID_HEVC, label_of(id)) {}

  void decode(std::span<const uint8_t> data, DepthImage& out) override {
    const char* label = label_of(id_);
    const Header hdr = read_header(data, label);
    const int bits = data[5];
    if (bits != (id_ == kH264 ? 10 : 12))
      throw Error(std::string(label) + ": corrupt header (bit depth)");
    const uint8_t* p = data.data() + kDepthHeaderBytes;
    const uint8_t* end = data.data() + data.size();
    if (end - p < 12) throw Error(std::string(label) + ": truncated stream");
    const int32_t near = p[0] | p[1] << 8, far = p[2] | p[3] << 8;
    const size_t mask_bytes =
        size_t{p[4]} | size_t{p[5]} << 8 | size_t{p[6]} << 16 | size_t{p[7]} << 24;
    const size_t packet_bytes =
        size_t{p[8]} | size_t{p[9]} << 8 | size_t{p[10]} << 16 | size_t{p[11]} << 24;
    p += 12;
    if (mask_bytes > static_cast<size_t>(end - p) ||
        packet_bytes != static_cast<size_t>(end - p) - mask_bytes)
      throw Error(std::string(label) + ": truncated stream (lengths do not match)");
    if (near < 1 || far <= near) throw Error(std::string(label) + ": corrupt header (range)");
    if (mask_bytes > static_cast<size_t>(end - p))
      throw Error(std::string(label) + ": truncated valid mask");
    const size_t n = hdr.pixels();
    runs_.resize(2 * n + 16);
    const size_t run_bytes = ZSTD_decompress(runs_.data(), runs_.size(), p, mask_bytes);
    if (ZSTD_isError(run_bytes)) throw Error(std::string(label) + ": corrupt valid mask");
    p += mask_bytes;
    const AVFrame* f = video_.decode({p, static_cast<size_t>(end - p)}, hdr.key);
    const AVPixelFormat want = id_ == kH264 ? AV_PIX_FMT_YUV420P10LE : AV_PIX_FMT_YUV420P12LE;
    if (f->format != want || f->width < hdr.width || f->height < hdr.height)
      throw Error(std::string(label) + ": the video does not match the header");

    if (out.width != hdr.width || out.height != hdr.height) out = DepthImage(hdr.width, hdr.height);
    const int32_t max_code = (1 << bits) - 1;
    const double step = static_cast<double>(far - near) / max_code;
    const uint8_t* r = runs_.data();
    const uint8_t* r_end = runs_.data() + run_bytes;
    size_t i = 0;
    const int w = hdr.width;
    while (i < n) {
      const uint32_t zeros = get_varint(r, r_end, label);
      const uint32_t valid = get_varint(r, r_end, label);
      if (zeros > n - i || valid > n - i - zeros || (zeros == 0 && valid == 0))
        throw Error(std::string(label) + ": corrupt valid mask");
      std::fill(out.pixels.begin() + static_cast<ptrdiff_t>(i),
                out.pixels.begin() + static_cast<ptrdiff_t>(i + zeros), uint16_t{0});
      i += zeros;
      for (const size_t stop = i + valid; i < stop; ++i) {
        const int y = static_cast<int>(i / static_cast<size_t>(w)),
                  x = static_cast<int>(i % static_cast<size_t>(w));
        const auto* row = reinterpret_cast<const uint16_t*>(f->data[0] + static_cast<ptrdiff_t>(y) *
                                                                             f->linesize[0]);
        const int32_t code = std::min<int32_t>(row[x], max_code);
        const int32_t d = near + static_cast<int32_t>(std::lround(code * step));
        out.pixels[i] = static_cast<uint16_t>(std::clamp(d, 1, 65535));
      }
    }
  }

 private:
  CodecId id_;
  VideoDecoder video_;
  std::vector<uint8_t> runs_;
};

// A BGRA row stride with room for swscale's vector loads and stores past the row's end.
int padded_stride(int width) {
  return (width * 4 + 64 + 63) & ~63;
}

class H264ColorEncoder final : public ColorEncoder {
 public:
  H264ColorEncoder() : video_("libx264", "h264 color", AV_PIX_FMT_YUV420P, kColorCrf) {}
  void set_quality(int quality) override {
    ColorEncoder::set_quality(quality);  // checks the range
    video_.set_crf(static_cast<int>(std::lround(51 - 0.45 * quality)));
  }
  ~H264ColorEncoder() override { sws_freeContext(sws_); }
  bool encode(const ColorImage& image, bool key_frame, std::vector<uint8_t>& out) override {
    out.clear();
    if (image.width == 0 || image.height == 0) return true;  // no color: nothing to send
    if (image.width % 2 || image.height % 2)
      throw Error("h264 color: odd image size " + std::to_string(image.width) + "x" +
                  std::to_string(image.height) + " (4:2:0 needs even sides)");
    AVFrame* f = video_.frame(image.width, image.height);
    sws_ = sws_getCachedContext(sws_, image.width, image.height, AV_PIX_FMT_BGRA, image.width,
                                image.height, AV_PIX_FMT_YUV420P, SWS_BILINEAR, nullptr, nullptr,
                                nullptr);
    if (!sws_) throw Error("h264 color: no BGRA to YUV 4:2:0 conversion");
    // swscale's SIMD reads (and writes) past the end of rows: give it padded rows.
    const int stride = padded_stride(image.width);
    scratch_.resize(static_cast<size_t>(stride) * (image.height + 1) + 64);
    for (int y = 0; y < image.height; ++y)
      std::copy_n(image.bgra.data() + static_cast<size_t>(y) * image.width * 4, image.width * 4,
                  scratch_.data() + static_cast<size_t>(y) * stride);
    const uint8_t* src[1] = {scratch_.data()};
    sws_scale(sws_, src, &stride, 0, image.height, f->data, f->linesize);
    out.resize(kColorHeaderBytes);
    const bool key = video_.encode(key_frame, out);
    write_color_header({kColorCodecH264, key, image.width, image.height}, out);
    return key;
  }
  std::string_view name() const override { return "h264"; }

 private:
  VideoEncoder video_;
  SwsContext* sws_ = nullptr;
  std::vector<uint8_t> scratch_;
};

class H264ColorDecoder final : public ColorDecoder {
 public:
  H264ColorDecoder() : video_(AV_CODEC_ID_H264, "h264 color") {}
  ~H264ColorDecoder() override { sws_freeContext(sws_); }
  void decode(std::span<const uint8_t> d, ColorImage& out) override {
    if (d.empty()) {
      out = ColorImage();
      return;
    }
    const std::optional<ColorHeader> header = read_color_header(d);
    if (!header || header->codec_id != kColorCodecH264)
      throw Error("h264 color: not a Volcast H.264 color frame");
    const int w = header->width, h = header->height;
    const AVFrame* f = video_.decode(d.subspan(kColorHeaderBytes), header->key);
    if (f->format != AV_PIX_FMT_YUV420P || f->width != w || f->height != h)
      throw Error("h264 color: the video does not match the header");
    if (out.width != w || out.height != h) out = ColorImage(w, h);
    sws_ = sws_getCachedContext(sws_, w, h, AV_PIX_FMT_YUV420P, w, h, AV_PIX_FMT_BGRA, SWS_BILINEAR,
                                nullptr, nullptr, nullptr);
    if (!sws_) throw Error("h264 color: no YUV 4:2:0 to BGRA conversion");
    // swscale's SIMD writes past the end of rows: convert into padded rows, then copy.
    const int stride = padded_stride(w);
    scratch_.resize(static_cast<size_t>(stride) * (h + 1) + 64);
    uint8_t* dst[1] = {scratch_.data()};
    sws_scale(sws_, f->data, f->linesize, 0, h, dst, &stride);
    for (int y = 0; y < h; ++y)
      std::copy_n(scratch_.data() + static_cast<size_t>(y) * stride, w * 4,
                  out.bgra.data() + static_cast<size_t>(y) * w * 4);
  }

 private:
  VideoDecoder video_;
  SwsContext* sws_ = nullptr;
  std::vector<uint8_t> scratch_;
};

}  // namespace

}  // namespace volcast::detail

namespace volcast {

void register_video_codecs() {
  static std::once_flag once;
  std::call_once(once, [] {
    using namespace detail;
    register_depth_codec(
        {"h264", kH264, false, -1, true,
         "H.264 video (x264, 10-bit): depth mapped over the key frame's range; exact valid mask",
         []() -> std::unique_ptr<DepthEncoder> {
           return std::make_unique<VideoDepthEncoder>(kH264);
         },
         []() -> std::unique_ptr<DepthDecoder> {
           return std::make_unique<VideoDepthDecoder>(kH264);
         },
         26});
    register_depth_codec(
        {"hevc", kHevc, false, -1, true,
         "HEVC video (x265, 12-bit): depth mapped over the key frame's range; exact valid mask",
         []() -> std::unique_ptr<DepthEncoder> {
           return std::make_unique<VideoDepthEncoder>(kHevc);
         },
         []() -> std::unique_ptr<DepthDecoder> {
           return std::make_unique<VideoDepthDecoder>(kHevc);
         },
         200});
    register_color_codec(
        {"h264", false, true, "H.264 video (x264, 8-bit 4:2:0, CRF 23), even sides only",
         []() -> std::unique_ptr<ColorEncoder> { return std::make_unique<H264ColorEncoder>(); },
         []() -> std::unique_ptr<ColorDecoder> { return std::make_unique<H264ColorDecoder>(); },
         28});
  });
}

}  // namespace volcast
