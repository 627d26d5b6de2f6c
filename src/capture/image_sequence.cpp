#include "volcast/capture/image_sequence.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>

#include "volcast/capture/camera_folder.hpp"
#include "volcast/capture/k4a_device.hpp"
#include "volcast/capture/k4a_recording.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/image_io.hpp"
#include "volcast/core/jpeg.hpp"

namespace volcast {
namespace {

namespace fs = std::filesystem;

std::vector<fs::path> list_files(const fs::path& dir, std::initializer_list<const char*> exts) {
  std::vector<fs::path> out;
  if (!fs::is_directory(dir)) return out;
  for (const auto& e : fs::directory_iterator(dir)) {
    std::string ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
    for (const char* want : exts)
      if (ext == want && e.is_regular_file()) out.push_back(e.path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::string size_text(int w, int h) {
  return std::to_string(w) + "x" + std::to_string(h);
}

ColorImage read_color(const fs::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
  if (ext == ".png") return read_color_png(path);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("cannot open '" + path.string() + "'");
  std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                             std::istreambuf_iterator<char>());
  if (in.bad()) throw Error("cannot read '" + path.string() + "'");
  ColorImage out;
  try {
    decode_jpeg(bytes, out);
  } catch (const Error& e) {
    throw Error("'" + path.string() + "': " + e.what());
  }
  return out;
}

// The frame rates a source may play at, frames per second.
constexpr double kMaxFps = 1000;

std::string number(double v) {
  std::ostringstream out;
  out << v;
  return out.str();
}

// Throws Error naming `where` unless fps is finite and in (0, kMaxFps].
void check_fps(double fps, const std::string& where) {
  if (!(std::isfinite(fps) && fps > 0 && fps <= kMaxFps))
    throw Error(where + ": fps must be a number in (0, " + number(kMaxFps) + "], got " +
                number(fps));
}

// Throws Error naming `where` and the field unless every value is finite and fx, fy are > 0.
void check_intrinsics(const Intrinsics& k, const std::string& where) {
  const std::pair<const char*, double> fields[] = {
      {"fx", k.fx}, {"fy", k.fy}, {"cx", k.cx}, {"cy", k.cy}, {"k1", k.k1}, {"k2", k.k2},
      {"k3", k.k3}, {"k4", k.k4}, {"k5", k.k5}, {"k6", k.k6}, {"p1", k.p1}, {"p2", k.p2}};
  for (const auto& [name, v] : fields)
    if (!std::isfinite(v)) throw Error(where + ": " + name + " must be finite, got " + number(v));
  if (!(k.fx > 0 && k.fy > 0))
    throw Error(where + ": fx and fy must be > 0, got " + number(k.fx) + " and " + number(k.fy));
}

struct SequenceConfig {
  std::optional<Intrinsics> intrinsics;
  std::optional<double> fps;
  std::optional<RigidTransform> world_from_camera;
};

SequenceConfig read_config(const fs::path& file) {
  SequenceConfig cfg;
  if (!fs::exists(file)) return cfg;
  std::ifstream in(file);
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {  // e.g. 1e999: JSON has no infinity
    throw Error("'" + file.string() + "' is not valid JSON: " + e.what());
  }
  if (!j.is_object()) throw Error("'" + file.string() + "' is not a JSON object");
  const std::string where = "'" + file.string() + "'";
  // A numeric field: `fallback` if absent (nullopt: required); Error naming it if not a number.
  auto field = [&](const char* name, std::optional<double> fallback) {
    if (!j.contains(name)) {
      if (fallback) return *fallback;
      throw Error(where + ": missing field \"" + name + "\"");
    }
    if (!j[name].is_number())
      throw Error(where + ": " + name + " must be a number, got " + j[name].dump());
    return j[name].get<double>();
  };
  try {
    Intrinsics k;
    k.fx = field("fx", std::nullopt), k.fy = field("fy", std::nullopt);
    k.cx = field("cx", std::nullopt), k.cy = field("cy", std::nullopt);
    k.k1 = field("k1", 0.0), k.k2 = field("k2", 0.0), k.k3 = field("k3", 0.0);
    k.k4 = field("k4", 0.0), k.k5 = field("k5", 0.0), k.k6 = field("k6", 0.0);
    k.p1 = field("p1", 0.0), k.p2 = field("p2", 0.0);
    check_intrinsics(k, where);
    cfg.intrinsics = k;
    if (j.contains("fps")) {
      cfg.fps = field("fps", std::nullopt);
      check_fps(*cfg.fps, where);
    }
    if (j.contains("world_from_camera")) {
      const auto& w = j.at("world_from_camera");
      RigidTransform t;
      const auto r = w.at("rotation").get<std::vector<double>>();
      const auto tr = w.at("translation").get<std::vector<double>>();
      if (r.size() != 9 || tr.size() != 3)
        throw Error("'" + file.string() +
                    "': world_from_camera needs 9 rotation and 3 translation values");
      for (int i = 0; i < 9; ++i) t.rotation(i / 3, i % 3) = r[static_cast<size_t>(i)];
      for (int i = 0; i < 3; ++i) t.translation[i] = tr[static_cast<size_t>(i)];
      if (!t.rotation.allFinite() || !t.translation.allFinite())
        throw Error("'" + file.string() + "': world_from_camera must be finite");
      cfg.world_from_camera = t;
    }
  } catch (const nlohmann::json::exception& e) {
    throw Error("'" + file.string() + "': missing or malformed field: " + e.what());
  }
  return cfg;
}

class ImageSequenceSource final : public FrameSource {
 public:
  ImageSequenceSource(const fs::path& dir, const SourceOptions& options) : dir_(dir) {
    if (!fs::is_directory(dir))
      throw Error("image sequence '" + dir.string() + "' is not a folder");
    depth_files_ = list_files(dir / "depth", {".png"});
    if (depth_files_.empty())
      throw Error("image sequence '" + dir.string() + "' has no 16-bit PNGs in depth/");
    std::map<std::string, fs::path> colors;
    for (const auto& c : list_files(dir / "color", {".jpg", ".jpeg", ".png"}))
      colors[c.stem().string()] = c;
    for (const auto& d : depth_files_) {
      auto it = colors.find(d.stem().string());
      color_files_.push_back(it == colors.end() ? fs::path() : it->second);
      color_frames_ += it != colors.end();
    }
    const DepthImage first = first_readable_depth();
    const SequenceConfig cfg = read_config(dir / "intrinsics.json");
    Intrinsics k;
    if (cfg.intrinsics) {
      k = *cfg.intrinsics;
    } else if (options.intrinsics) {
      k = *options.intrinsics;
      check_intrinsics(k, "image sequence '" + dir.string() + "': --intrinsics");
      if ((k.width > 0 && k.width != first.width) || (k.height > 0 && k.height != first.height))
        throw Error("image sequence '" + dir.string() + "' is " +
                    size_text(first.width, first.height) + ", its intrinsics are for " +
                    size_text(k.width, k.height) + " images");
    } else {
      const double f = first.width / 2.0 / std::tan(35.0 * std::numbers::pi / 180.0);
      k.fx = k.fy = f;
      k.cx = (first.width - 1) / 2.0;
      k.cy = (first.height - 1) / 2.0;
      spdlog::warn(
          "!!! {} has no intrinsics.json and no --intrinsics was given: using a NOMINAL "
          "pinhole (fx = fy = {:.1f}, cx = {:.1f}, cy = {:.1f}, 70 deg horizontal FOV). "
          "Point clouds will be scaled wrong if the real camera differs. !!!",
          dir.string(), f, k.cx, k.cy);
    }
    k.width = first.width;
    k.height = first.height;
    calibration_.depth = k;
    calibration_.world_from_camera = options.world_from_camera.value_or(
        cfg.world_from_camera.value_or(RigidTransform::identity()));
    if (options.fps) check_fps(*options.fps, "image sequence '" + dir.string() + "'");
    fps_ = options.fps.value_or(cfg.fps.value_or(30.0));
  }

  const CameraCalibration& calibration() const override { return calibration_; }
  double fps() const override { return fps_; }
  int frame_count() const override { return static_cast<int>(depth_files_.size()); }
  int color_frame_count() const override { return color_frames_; }
  std::string description() const override { return "image sequence " + dir_.string(); }

  // The index moves on before reading: a frame that cannot be read is skipped, never retried.
  void next(CameraFrame& f) override {
    const uint64_t n = index_++;
    const size_t i = n % depth_files_.size();
    f.depth = read_depth_png(depth_files_[i]);
    const Intrinsics& k = calibration_.depth;
    if (f.depth.width != k.width || f.depth.height != k.height)
      throw Error("'" + depth_files_[i].string() + "' is " +
                  size_text(f.depth.width, f.depth.height) + ", the sequence's depth frames are " +
                  size_text(k.width, k.height));
    if (!color_files_[i].empty()) {
      f.color = read_color(color_files_[i]);
      if (f.color.width != k.width || f.color.height != k.height)
        throw Error("'" + color_files_[i].string() + "' is " +
                    size_text(f.color.width, f.color.height) +
                    ", not registered to its depth frame (" + size_text(k.width, k.height) + ")");
    } else {
      f.color = ColorImage();  // no color for this frame
    }
    f.device_timestamp_us = static_cast<int64_t>(static_cast<double>(n) * 1e6 / fps_);
  }

 private:
  // The first depth frame that reads (it sets the sequence's size); unreadable ones before it are
  // left to next() to skip. Throws Error with the first file's error if none reads.
  DepthImage first_readable_depth() const {
    std::string first_error;
    for (const auto& file : depth_files_) {
      try {
        return read_depth_png(file);
      } catch (const Error& e) {
        if (first_error.empty()) first_error = e.what();
      }
    }
    throw Error("image sequence '" + dir_.string() + "': no depth frame can be read (" +
                first_error + ")");
  }

  fs::path dir_;
  std::vector<fs::path> depth_files_, color_files_;
  CameraCalibration calibration_;
  double fps_ = 30;
  uint64_t index_ = 0;
  int color_frames_ = 0;  // depth frames with a color file
};

}  // namespace

std::unique_ptr<FrameSource> open_image_sequence(const fs::path& dir,
                                                 const SourceOptions& options) {
  return std::make_unique<ImageSequenceSource>(dir, options);
}

std::unique_ptr<FrameSource> open_source(const fs::path& path, const SourceOptions& options) {
  if (is_k4a_device_url(path.string())) return open_k4a_device(path.string(), options);
  if (fs::is_directory(path)) {
    // A camera folder (depth.<serial>-<n>.png side by side) is several cameras, not one.
    const auto cameras = list_folder_cameras(path);
    if (!cameras.empty() && !fs::is_directory(path / "depth")) {
      std::string serials;
      for (const auto& c : cameras) serials += (serials.empty() ? "" : ", ") + c.serial;
      throw Error("source '" + path.string() + "' holds " + std::to_string(cameras.size()) +
                  (cameras.size() == 1 ? " camera" : " cameras") + " (depth.<serial>-*.png of " +
                  serials + "), not an image sequence: pass one depth.<serial>-*.png per camera " +
                  "as a source (with intrinsics), or use --config with a site config (volcast " +
                  "calibrate writes one)");
    }
    return open_image_sequence(path, options);
  }
  if (!fs::exists(path)) throw Error("source '" + path.string() + "' does not exist");
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
  if (ext == ".mkv") return open_k4a_recording(path, options);
  if (ext == ".png") return open_folder_camera(path, options);
  throw Error(
      "source '" + path.string() +
      "' is neither a folder (image sequence), an Azure Kinect recording (.mkv) nor a depth PNG");
}

}  // namespace volcast
