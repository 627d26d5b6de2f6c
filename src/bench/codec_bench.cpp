#include "codec_bench.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>

#include "volcast/capture/source.hpp"
#include "volcast/codec/color_codec.hpp"
#include "volcast/codec/depth_codec.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/image_io.hpp"
#include "volcast/filter/filters.hpp"

namespace volcast {
namespace fs = std::filesystem;
namespace {

struct CodecSet {
  std::string name;
  std::vector<DepthImage> depth;
  std::vector<ColorImage> color;  // registered color, or empty
  int key_interval = 0;           // key frame every N frames (0: only the first)
};

struct DepthRow {
  std::string codec;
  double bytes = 0, encode_ms = 0, decode_ms = 0, max_error = 0, mean_error = 0;
  size_t mask_errors = 0;  // pixels invalid in the input but not in the output
  bool lossless = true;
};

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

double ms_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t).count();
}

DepthRow run_depth(const CodecSet& s, const std::string& label,
                   const std::function<std::unique_ptr<DepthEncoder>()>& make_encoder,
                   const std::string& decoder, int repeats) {
  DepthRow row;
  row.codec = label;
  std::vector<double> enc_ms, dec_ms;
  std::vector<std::vector<uint8_t>> streams(s.depth.size());
  // One encoder and decoder for all passes (buffers warm, as in a running server); each pass
  // starts with a key frame.
  auto enc = make_encoder();
  for (int r = 0; r < repeats; ++r) {
    const auto t = std::chrono::steady_clock::now();
    for (size_t i = 0; i < s.depth.size(); ++i)
      enc->encode(s.depth[i],
                  i == 0 || (s.key_interval && i % static_cast<size_t>(s.key_interval) == 0),
                  streams[i]);
    enc_ms.push_back(ms_since(t) / static_cast<double>(s.depth.size()));
  }
  DepthImage out;
  auto dec = make_depth_decoder(decoder);
  for (int r = 0; r < repeats; ++r) {
    const auto t = std::chrono::steady_clock::now();
    for (const auto& b : streams) dec->decode(b, out);
    dec_ms.push_back(ms_since(t) / static_cast<double>(s.depth.size()));
  }
  // Exactness on every frame and pixel.
  double error_sum = 0;
  size_t pixels = 0;
  for (size_t i = 0; i < s.depth.size(); ++i) {
    row.bytes += static_cast<double>(streams[i].size());
    dec->decode(streams[i], out);
    for (size_t p = 0; p < out.size(); ++p) {
      const double e = std::abs(double(out.pixels[p]) - double(s.depth[i].pixels[p]));
      row.max_error = std::max(row.max_error, e);
      if (s.depth[i].pixels[p] == 0 && e != 0) ++row.mask_errors;
      if (s.depth[i].pixels[p] == 0) continue;  // the mean is over valid pixels
      error_sum += e;
      ++pixels;
    }
  }
  row.bytes /= static_cast<double>(s.depth.size());
  row.mean_error = pixels ? error_sum / static_cast<double>(pixels) : 0;
  row.lossless = row.max_error == 0;
  row.encode_ms = median(enc_ms);
  row.decode_ms = median(dec_ms);
  return row;
}

std::vector<CodecSet> load_sets(const fs::path& data, const std::vector<std::string>& extra,
                                int limit) {
  std::vector<CodecSet> sets;
  auto from_source = [&](const fs::path& path, const std::string& name, int max_frames) {
    if (limit > 0) max_frames = std::min(max_frames, limit);
    SourceOptions o;
    o.intrinsics = Intrinsics{0, 0, 460, 460, 320, 180};  // only used where a folder has none
    auto src = open_source(path, o);
    CodecSet s{name, {}, {}, 0};
    for (int i = 0; i < std::min(max_frames, src->frame_count()); ++i) {
      CameraFrame f = src->next();
      s.depth.push_back(std::move(f.depth));
      if (!f.color.empty()) s.color.push_back(std::move(f.color));
    }
    sets.push_back(std::move(s));
  };
  if (fs::exists(data / "k4a-recording" / "recording.mkv"))
    from_source(data / "k4a-recording" / "recording.mkv", "k4a-recording 640x576", 1);
  auto from_pngs = [&](const fs::path& dir, const std::string& prefix, const std::string& name,
                       int key_interval) {
    if (!fs::exists(dir)) return;
    std::vector<fs::path> files;
    for (const auto& e : fs::directory_iterator(dir))
      if (e.path().extension() == ".png" && e.path().filename().string().rfind(prefix, 0) == 0)
        files.push_back(e.path());
    std::sort(files.begin(), files.end());
    CodecSet s{name, {}, {}, key_interval};
    for (const auto& f : files) s.depth.push_back(read_depth_png(f));
    if (!s.depth.empty()) sets.push_back(std::move(s));
  };
  from_pngs(data / "k4a-4cam-nfov", "depth", "k4a-4cam-nfov 640x576",
            1);  // four cameras: all key frames
  from_pngs(data / "k4a-binned-pairs", "TestVector", "k4a-binned-pairs 320x288",
            2);  // key, delta pairs
  if (fs::exists(data / "rgbd-hands-640x360"))
    from_source(data / "rgbd-hands-640x360", "rgbd-hands 640x360", 207);
  for (const auto& e : extra) from_source(e, fs::path(e).filename().string(), 300);
  return sets;
}

// A rectangle of `image` (rect inside it).
ColorImage crop(const ColorImage& image, const CropRect& rect) {
  ColorImage out(rect.width, rect.height);
  for (int y = 0; y < rect.height; ++y)
    std::copy_n(
        image.bgra.begin() + (static_cast<ptrdiff_t>(rect.y + y) * image.width + rect.x) * 4,
        rect.width * 4, out.bgra.begin() + static_cast<ptrdiff_t>(y) * rect.width * 4);
  return out;
}

// Streams `images` through `codec` at `quality` (0: its default; key frame first, as a viewer
// receives them), `repeats` passes; adds a "color_codecs" entry and returns the mean bytes per
// frame.
double bench_color(const std::string& set, const std::string& codec,
                   const std::vector<ColorImage>& images, int repeats, nlohmann::json& json,
                   int quality = 0) {
  std::vector<std::vector<uint8_t>> streams(images.size());
  std::vector<double> enc_ms, dec_ms;
  auto enc = make_color_encoder(codec);
  if (quality > 0) enc->set_quality(quality);
  auto dec = make_color_decoder(codec);
  ColorImage out;
  for (int r = 0; r < repeats; ++r) {
    auto t = std::chrono::steady_clock::now();
    for (size_t i = 0; i < images.size(); ++i) enc->encode(images[i], i == 0, streams[i]);
    enc_ms.push_back(ms_since(t) / static_cast<double>(images.size()));
    t = std::chrono::steady_clock::now();
    for (const auto& b : streams) dec->decode(b, out);
    dec_ms.push_back(ms_since(t) / static_cast<double>(images.size()));
  }
  double bytes = 0, se = 0, samples = 0;
  for (size_t i = 0; i < images.size(); ++i) {
    bytes += static_cast<double>(streams[i].size());
    dec->decode(streams[i], out);
    for (size_t p = 0; p < out.bgra.size(); p += 4)
      for (int k = 0; k < 3; ++k, ++samples)
        se += std::pow(double(out.bgra[p + k]) - images[i].bgra[p + k], 2);
  }
  bytes /= static_cast<double>(images.size());
  const double raw = static_cast<double>(images[0].width) * images[0].height * 3;
  json["color_codecs"].push_back({{"dataset", set},
                                  {"codec", codec},
                                  {"quality", quality},
                                  {"bytes_per_frame", bytes},
                                  {"ratio", raw / bytes},
                                  {"encode_ms", median(enc_ms)},
                                  {"decode_ms", median(dec_ms)},
                                  {"psnr_db", 10 * std::log10(255.0 * 255.0 / (se / samples))}});
  return bytes;
}

}  // namespace

void bench_codecs(const fs::path& data, const std::vector<std::string>& extra, int repeats,
                  int max_frames, nlohmann::json& json) {
  const std::vector<CodecSet> sets = load_sets(data, extra, max_frames);
  if (sets.empty()) throw Error("bench: no data found in " + data.string());
  json["depth_codecs"] = nlohmann::json::array();
  json["color_codecs"] = nlohmann::json::array();
  std::printf("\nDepth codecs (paper's Table 1 layout), one thread, median of %d passes\n",
              repeats);
  std::printf("%-26s %-11s %10s %7s %8s %8s %-14s %9s %8s %8s %8s\n", "dataset", "codec", "B/frame",
              "ratio", "enc ms", "dec ms", "exact", "Mbit/s*", "ratio/R", "enc/R", "dec/R");
  for (const CodecSet& s : sets) {
    // Color that travels with this camera (JPEG of the registered color, where the set has it),
    // and the alternatives: H.264 and JPEG of the NFOV crop (what a cropped camera sends).
    double color_bytes = 0;
    if (!s.color.empty()) {
      color_bytes = bench_color(s.name, "jpeg", s.color, repeats, json);
      bench_color(s.name, "h264", s.color, repeats, json);
      // The tier ladder's color qualities (net/stream/server.hpp default_ladder): size against
      // PSNR, to choose the default tier's quality by measurement.
      for (const int q : {80, 70, 60, 50, 40})
        bench_color(s.name, "jpeg", s.color, repeats, json, q);
      bench_color(s.name, "h264", s.color, repeats, json, 50);
      if (s.color[0].width == 640 && s.color[0].height == 576) {
        std::vector<ColorImage> cropped;
        for (const auto& c : s.color) cropped.push_back(crop(c, kNfovCrop));
        bench_color(s.name + " crop 540x476", "jpeg", cropped, repeats, json);
      }
    }
    std::vector<DepthRow> rows;
    for (const std::string& codec : depth_codec_names())
      rows.push_back(run_depth(
          s, codec, [&] { return make_depth_encoder(codec); }, codec, repeats));
    // The paper's temporal RVL setting (changes <= 10 mm dropped, invalid held 2 frames): lossy.
    rows.push_back(run_depth(
        s, "trvl-paper",
        [] {
          return make_trvl_encoder({10, 2});
        },
        "trvl", repeats));
    const DepthRow& rvl =
        *std::find_if(rows.begin(), rows.end(), [](const DepthRow& r) { return r.codec == "rvl"; });
    const double raw = static_cast<double>(s.depth[0].size()) * 2;
    for (const DepthRow& r : rows) {
      const double mbit = (r.bytes + color_bytes) * 8 * 30 / 1e6;
      const std::string exact =
          r.lossless ? "lossless"
                     : fmt::format("max {:.0f} mean {:.2f}", r.max_error, r.mean_error);
      std::printf("%-26s %-11s %10.0f %6.2fx %8.3f %8.3f %-14s %9.2f %8.2f %8.2f %8.2f\n",
                  s.name.c_str(), r.codec.c_str(), r.bytes, raw / r.bytes, r.encode_ms, r.decode_ms,
                  exact.c_str(), mbit, rvl.bytes / r.bytes, r.encode_ms / rvl.encode_ms,
                  r.decode_ms / rvl.decode_ms);
      json["depth_codecs"].push_back({{"dataset", s.name},
                                      {"frames", s.depth.size()},
                                      {"codec", r.codec},
                                      {"bytes_per_frame", r.bytes},
                                      {"ratio", raw / r.bytes},
                                      {"encode_ms", r.encode_ms},
                                      {"decode_ms", r.decode_ms},
                                      {"lossless", r.lossless},
                                      {"max_abs_error_mm", r.max_error},
                                      {"mean_abs_error_mm", r.mean_error},
                                      {"invalid_made_valid", r.mask_errors},
                                      {"mbit_per_s_with_color", mbit},
                                      {"ratio_vs_rvl", rvl.bytes / r.bytes},
                                      {"encode_vs_rvl", r.encode_ms / rvl.encode_ms},
                                      {"decode_vs_rvl", r.decode_ms / rvl.decode_ms}});
    }
  }
  std::printf(
      "* depth + JPEG color per camera (first color row of the set) at 30 fps (depth only where a "
      "set has no registered "
      "color);\n"
      "  ratio/R, enc/R, dec/R: against RVL in the same run (ratio/R > 1 = smaller than RVL).\n");
  for (const auto& c : json["color_codecs"])
    std::printf(
        "color %-38s %-5s q%-3d %8.0f B/frame %6.2fx  enc %.3f ms  dec %.3f ms  PSNR %.1f dB\n",
        c["dataset"].get<std::string>().c_str(), c["codec"].get<std::string>().c_str(),
        c["quality"].get<int>(), c["bytes_per_frame"].get<double>(), c["ratio"].get<double>(),
        c["encode_ms"].get<double>(), c["decode_ms"].get<double>(), c["psnr_db"].get<double>());
}

}  // namespace volcast
