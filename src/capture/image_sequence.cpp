#include "volcast/capture/image_sequence.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>

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

ColorImage read_color(const fs::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
  if (ext == ".png") return read_color_png(path);
  std::ifstream in(path, std::ios::binary);
  std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                             std::istreambuf_iterator<char>());
  if (!in.good() && !in.eof()) throw Error("cannot read '" + path.string() + "'");
  ColorImage out;
  try {
    decode_jpeg(bytes, out);
  } catch (const Error& e) {
    throw Error("'" + path.string() + "': " + e.what());
  }
  return out;
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
  nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
  if (j.is_discarded() || !j.is_object())
    throw Error("'" + file.string() + "' is not a JSON object");
  try {
    Intrinsics k;
    k.fx = j.at("fx").get<double>();
    k.fy = j.at("fy").get<double>();
    k.cx = j.at("cx").get<double>();
    k.cy = j.at("cy").get<double>();
    k.k1 = j.value("k1", 0.0), k.k2 = j.value("k2", 0.0), k.k3 = j.value("k3", 0.0);
    k.k4 = j.value("k4", 0.0), k.k5 = j.value("k5", 0.0), k.k6 = j.value("k6", 0.0);
    k.p1 = j.value("p1", 0.0), k.p2 = j.value("p2", 0.0);
    if (!(k.fx > 0 && k.fy > 0)) throw Error("'" + file.string() + "': fx and fy must be > 0");
    cfg.intrinsics = k;
    if (j.contains("fps")) cfg.fps = j.at("fps").get<double>();
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
    }
    const DepthImage first = read_depth_png(depth_files_.front());
    const SequenceConfig cfg = read_config(dir / "intrinsics.json");
    Intrinsics k;
    if (cfg.intrinsics) {
      k = *cfg.intrinsics;
    } else if (options.intrinsics) {
      k = *options.intrinsics;
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
    fps_ = options.fps.value_or(cfg.fps.value_or(30.0));
  }

  const CameraCalibration& calibration() const override { return calibration_; }
  double fps() const override { return fps_; }
  int frame_count() const override { return static_cast<int>(depth_files_.size()); }
  std::string description() const override { return "image sequence " + dir_.string(); }

  CameraFrame next() override {
    const size_t i = index_ % depth_files_.size();
    CameraFrame f;
    f.depth = read_depth_png(depth_files_[i]);
    const Intrinsics& k = calibration_.depth;
    if (f.depth.width != k.width || f.depth.height != k.height)
      throw Error("'" + depth_files_[i].string() + "' differs in size from the first depth frame");
    if (!color_files_[i].empty()) {
      f.color = read_color(color_files_[i]);
      if (f.color.width != k.width || f.color.height != k.height)
        throw Error("'" + color_files_[i].string() + "' is not registered to depth (size differs)");
    }
    f.device_timestamp_us = static_cast<int64_t>(static_cast<double>(index_) * 1e6 / fps_);
    ++index_;
    return f;
  }

 private:
  fs::path dir_;
  std::vector<fs::path> depth_files_, color_files_;
  CameraCalibration calibration_;
  double fps_ = 30;
  uint64_t index_ = 0;
};

}  // namespace

std::unique_ptr<FrameSource> open_image_sequence(const fs::path& dir,
                                                 const SourceOptions& options) {
  return std::make_unique<ImageSequenceSource>(dir, options);
}

std::unique_ptr<FrameSource> open_source(const fs::path& path, const SourceOptions& options) {
  if (fs::is_directory(path)) return open_image_sequence(path, options);
  if (!fs::exists(path)) throw Error("source '" + path.string() + "' does not exist");
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
  if (ext == ".mkv") return open_k4a_recording(path, options);
  throw Error("source '" + path.string() +
              "' is neither a folder (image sequence) nor an Azure Kinect recording (.mkv)");
}

}  // namespace volcast
