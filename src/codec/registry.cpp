// The codec table (registry.hpp): the pure codecs listed here, more added by register_*_codec().
#include "volcast/codec/registry.hpp"

#include <deque>
#include <mutex>

#include "builtin_codecs.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/jpeg.hpp"

namespace volcast {
namespace {

using namespace detail;

// Depth codecs of this library, in the order --help and the bench list them. The last figure of
// each: encode ns per pixel (registry.hpp), the most over the four shared recordings.
constexpr DepthCodecInfo kPureDepthCodecs[] = {
    {"raw", kRaw, true, 0, false, "uint16 little-endian samples (the baseline for ratios)",
     make_raw_depth_encoder, make_raw_depth_decoder, 0.2},
    {"rvl", kRvl, true, 0, false,
     "RVL (Wilson 2017): runs of invalid pixels, nibble-coded deltas of the valid ones",
     make_rvl_encoder, make_rvl_decoder, 7},
    {"trvl", kTrvl, true, 0, true,
     "temporal RVL (Jun & Bailenson 2020), lossless thresholds: delta frames code per-pixel "
     "changes",
     [] { return make_trvl_encoder({}); }, make_trvl_decoder, 11},
    {"zstd", kZstd, true, 0, false, "Zstandard (level 1) after a left-delta and byte-plane split",
     [] { return make_byte_plane_encoder(kZstd); }, [] { return make_byte_plane_decoder(kZstd); },
     6.5},
    {"lz4", kLz4, true, 0, false, "LZ4 after the same left-delta and byte-plane split",
     [] { return make_byte_plane_encoder(kLz4); }, [] { return make_byte_plane_decoder(kLz4); },
     4.5},
    {"volcast", kVolcast, true, 0, false,
     "Volcast's own: runs, LOCO-I prediction, activity contexts, four-lane rANS",
     [] { return make_volcast_encoder(0); }, make_volcast_decoder, 5},
    {"volcast-t", kVolcast, true, 0, true,
     "volcast with per-16x16-block prediction from the last frame between key frames",
     [] { return make_volcast_encoder(0, true); }, make_volcast_decoder, 7},
    {"volcast-n1", kVolcast, false, 1, false,
     "volcast on depth quantised in steps of 3 mm: every valid pixel within 1 mm",
     [] { return make_volcast_encoder(1); }, make_volcast_decoder, 9},
    {"volcast-n2", kVolcast, false, 2, false,
     "volcast on depth quantised in steps of 5 mm: every valid pixel within 2 mm",
     [] { return make_volcast_encoder(2); }, make_volcast_decoder, 6},
    {"volcast-n4", kVolcast, false, 4, false,
     "volcast on depth quantised in steps of 9 mm: every valid pixel within 4 mm",
     [] { return make_volcast_encoder(4); }, make_volcast_decoder, 9},
};

constexpr ColorCodecInfo kPureColorCodecs[] = {
    {"jpeg", false, false, "JPEG (libjpeg-turbo), 4:2:0, quality 90", make_jpeg_color_encoder,
     make_jpeg_color_decoder, 6},
    {"raw", true, false, "BGRA as is behind a 12-byte header", make_raw_color_encoder,
     make_raw_color_decoder, 0.5},
    {"none", false, false, "no color is sent; decodes to an empty image", make_none_color_encoder,
     make_none_color_decoder, 0},
};

// Names other libraries provide, for a hint when they are asked for but not registered.
constexpr std::string_view kVideoHint =
    "; h264 and hevc come with volcast_codec_video's register_video_codecs()";

struct Registry {
  std::mutex mutex;
  std::deque<DepthCodecInfo> depth;  // a deque: references stay valid as entries are added
  std::deque<ColorCodecInfo> color;

  Registry() {
    depth.assign(std::begin(kPureDepthCodecs), std::end(kPureDepthCodecs));
    color.assign(std::begin(kPureColorCodecs), std::end(kPureColorCodecs));
  }
};

// Built on first use (a function-local static: thread-safe, no initialisation-order dependence).
Registry& registry() {
  static Registry r;
  return r;
}

template <typename Info>
const Info* find(const std::deque<Info>& table, std::string_view name) {
  for (const Info& info : table)
    if (info.name == name) return &info;
  return nullptr;
}

template <typename Info>
std::string names(const std::deque<Info>& table) {
  std::string s;
  for (const Info& info : table) s += (s.empty() ? "" : ", ") + std::string(info.name);
  return s;
}

template <typename Info>
void add(std::deque<Info>& table, const Info& info, const char* kind) {
  if (info.name.empty() || !info.make_encoder || !info.make_decoder)
    throw Error(std::string("register ") + kind + " codec: needs a name and both factories");
  if (find(table, info.name))
    throw Error(std::string("register ") + kind + " codec: '" + std::string(info.name) +
                "' is already registered");
  table.push_back(info);
}

template <typename Info>
const Info& lookup(std::deque<Info>& table, std::string_view name, const char* kind,
                   bool video_name) {
  if (const Info* info = find(table, name)) return *info;
  std::string message = std::string("unknown ") + kind + " codec '" + std::string(name) +
                        "' (available: " + names(table);
  if (video_name) message += kVideoHint;
  throw Error(message + ")");
}

}  // namespace

void register_depth_codec(const DepthCodecInfo& info) {
  if (info.max_error_mm < -1 || info.lossless != (info.max_error_mm == 0))
    throw Error("register depth codec: '" + std::string(info.name) +
                "' must be lossless exactly when its max_error_mm is 0 (-1: unbounded)");
  Registry& r = registry();
  const std::lock_guard lock(r.mutex);
  add(r.depth, info, "depth");
}

void register_color_codec(const ColorCodecInfo& info) {
  Registry& r = registry();
  const std::lock_guard lock(r.mutex);
  add(r.color, info, "color");
}

const DepthCodecInfo* find_depth_codec(std::string_view name) {
  Registry& r = registry();
  const std::lock_guard lock(r.mutex);
  return find(r.depth, name);
}

const ColorCodecInfo* find_color_codec(std::string_view name) {
  Registry& r = registry();
  const std::lock_guard lock(r.mutex);
  return find(r.color, name);
}

const DepthCodecInfo& depth_codec_info(std::string_view name) {
  Registry& r = registry();
  const std::lock_guard lock(r.mutex);
  return lookup(r.depth, name, "depth", name == "h264" || name == "hevc");
}

const ColorCodecInfo& color_codec_info(std::string_view name) {
  Registry& r = registry();
  const std::lock_guard lock(r.mutex);
  return lookup(r.color, name, "color", name == "h264");
}

std::vector<DepthCodecInfo> all_depth_codecs() {
  Registry& r = registry();
  const std::lock_guard lock(r.mutex);
  return {r.depth.begin(), r.depth.end()};
}

std::vector<ColorCodecInfo> all_color_codecs() {
  Registry& r = registry();
  const std::lock_guard lock(r.mutex);
  return {r.color.begin(), r.color.end()};
}

std::string depth_codec_help() {
  std::string s;
  for (const DepthCodecInfo& c : all_depth_codecs()) {
    std::string what = c.max_error_mm == 0  ? "lossless"
                       : c.max_error_mm > 0 ? "within " + std::to_string(c.max_error_mm) + " mm"
                                            : "lossy";
    if (c.temporal) what += ", temporal";
    s += (s.empty() ? "" : ", ") + std::string(c.name) + " (" + what + ")";
  }
  return s;
}

std::string color_codec_help() {
  std::string s;
  for (const ColorCodecInfo& c : all_color_codecs()) {
    s += (s.empty() ? "" : ", ") + std::string(c.name);
    if (c.name == "none") continue;  // sends nothing: neither lossless nor lossy
    s += c.lossless ? " (lossless" : " (lossy";
    s += c.temporal ? ", temporal)" : ")";
  }
  return s;
}

std::vector<std::string> depth_codec_names() {
  std::vector<std::string> out;
  for (const DepthCodecInfo& c : all_depth_codecs()) out.emplace_back(c.name);
  return out;
}

std::vector<std::string> color_codec_names() {
  std::vector<std::string> out;
  for (const ColorCodecInfo& c : all_color_codecs()) out.emplace_back(c.name);
  return out;
}

std::optional<DeclaredSize> declared_depth_size(std::span<const uint8_t> f) {
  if (f.size() < kDepthHeaderBytes || f[0] != 'V' || f[1] != 'D') return std::nullopt;
  return DeclaredSize{f[8] | f[9] << 8, f[10] | f[11] << 8};
}

std::optional<DeclaredSize> declared_color_size(std::span<const uint8_t> f) {
  if (const std::optional<ColorHeader> h = read_color_header(f))
    return DeclaredSize{h->width, h->height};
  if (f.size() >= 2 && f[0] == 0xff && f[1] == 0xd8) {
    DeclaredSize size;
    try {
      jpeg_size(f, size.width, size.height);
    } catch (const Error&) {
      return std::nullopt;
    }
    return size;
  }
  return std::nullopt;
}

std::unique_ptr<DepthEncoder> make_depth_encoder(std::string_view name) {
  return depth_codec_info(name).make_encoder();
}
std::unique_ptr<DepthDecoder> make_depth_decoder(std::string_view name) {
  return depth_codec_info(name).make_decoder();
}
std::unique_ptr<ColorEncoder> make_color_encoder(std::string_view name) {
  return color_codec_info(name).make_encoder();
}
std::unique_ptr<ColorDecoder> make_color_decoder(std::string_view name) {
  return color_codec_info(name).make_decoder();
}

}  // namespace volcast
