#include "volcast/capture/camera_folder.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>

#include "volcast/capture/still_source.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/image_io.hpp"

namespace volcast {
namespace fs = std::filesystem;
namespace {

constexpr double kMaxFps = 1000;

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

std::string size_text(int width, int height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

// "<prefix><serial>-<n>.<ext>" -> serial and n (digits); false for any other name.
bool parse_name(const std::string& name, const std::string& prefix, std::string& serial,
                std::string& number) {
  if (name.rfind(prefix, 0) != 0) return false;
  const size_t dot = name.rfind('.');
  if (dot == std::string::npos || dot <= prefix.size()) return false;
  const size_t dash = name.rfind('-', dot);
  if (dash == std::string::npos || dash <= prefix.size()) return false;
  serial = name.substr(prefix.size(), dash - prefix.size());
  number = name.substr(dash + 1, dot - dash - 1);
  return !number.empty() && std::all_of(number.begin(), number.end(),
                                        [](unsigned char c) { return std::isdigit(c) != 0; });
}

// Frames of one camera decoded in next(), as an image sequence does.
class FolderSource final : public FrameSource {
 public:
  FolderSource(FolderCamera camera, CameraCalibration calibration, double fps)
      : camera_(std::move(camera)), calibration_(std::move(calibration)), fps_(fps) {}
  const CameraCalibration& calibration() const override { return calibration_; }
  double fps() const override { return fps_; }
  int frame_count() const override { return static_cast<int>(camera_.depth.size()); }
  int color_frame_count() const override {
    return static_cast<int>(std::count_if(camera_.color.begin(), camera_.color.end(),
                                          [](const fs::path& p) { return !p.empty(); }));
  }
  // The index moves on before reading: a frame that cannot be read is skipped, never retried.
  void next(CameraFrame& out) override {
    const uint64_t n = index_++;
    const size_t i = n % camera_.depth.size();
    const int width = calibration_.depth.width, height = calibration_.depth.height;
    out.depth = read_depth_png(camera_.depth[i]);
    if (out.depth.width != width || out.depth.height != height)
      throw Error("camera folder: '" + camera_.depth[i].string() + "' is " +
                  size_text(out.depth.width, out.depth.height) + ", camera " + camera_.serial +
                  "'s frames are " + size_text(width, height));
    if (camera_.color[i].empty()) {
      out.color = ColorImage();  // no color for this frame
    } else {
      ColorImage color = read_color_image(camera_.color[i]);
      out.color = color.width == width && color.height == height
                      ? std::move(color)
                      : resample_nearest(color, width, height);
    }
    out.device_timestamp_us = static_cast<int64_t>(static_cast<double>(n) * 1e6 / fps_);
  }
  std::string description() const override {
    return "camera folder " + camera_.depth.front().parent_path().string() + " serial " +
           camera_.serial + " (" + std::to_string(camera_.depth.size()) + " frames)";
  }

 private:
  FolderCamera camera_;
  CameraCalibration calibration_;
  double fps_;
  uint64_t index_ = 0;
};

// The first depth frame of `camera` that reads (it sets the camera's size); unreadable ones
// before it are left to next() to skip. Throws Error with the first file's error if none reads.
DepthImage first_readable_depth(const FolderCamera& camera) {
  std::string first_error;
  for (const auto& file : camera.depth) {
    try {
      return read_depth_png(file);
    } catch (const Error& e) {
      if (first_error.empty()) first_error = e.what();
    }
  }
  throw Error("camera folder: no depth frame of camera " + camera.serial + " can be read (" +
              first_error + ")");
}

// Error unless intrinsics given with a width/height are for a `width` x `height` image.
void check_size(const Intrinsics& k, int width, int height, const fs::path& file) {
  if ((k.width > 0 && k.width != width) || (k.height > 0 && k.height != height))
    throw Error("source '" + file.string() + "' is " + size_text(width, height) +
                ", its intrinsics are for " + size_text(k.width, k.height) + " images");
}

}  // namespace

std::vector<FolderCamera> list_folder_cameras(const fs::path& dir) {
  std::map<std::string, std::map<std::string, fs::path>> depth, color;  // serial -> n -> file
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    const std::string ext = lower(it->path().extension().string());
    std::string serial, number;
    if (ext == ".png" && parse_name(name, "depth.", serial, number))
      depth[serial][number] = it->path();
    else if ((ext == ".png" || ext == ".jpg" || ext == ".jpeg") &&
             parse_name(name, "rgb.", serial, number))
      color[serial][number] = it->path();
  }
  std::vector<FolderCamera> out;
  for (const auto& [serial, frames] : depth) {
    FolderCamera c;
    c.serial = serial;
    const auto colors = color.find(serial);
    for (const auto& [number, path] : frames) {
      c.depth.push_back(path);
      fs::path match;
      if (colors != color.end())
        if (const auto found = colors->second.find(number); found != colors->second.end())
          match = found->second;
      c.color.push_back(match);
    }
    out.push_back(std::move(c));
  }
  return out;
}

std::unique_ptr<FrameSource> open_folder_camera(const fs::path& depth_png,
                                                const SourceOptions& options) {
  if (!options.intrinsics)
    throw Error("source '" + depth_png.string() +
                "': a depth PNG carries no intrinsics; it needs them from elsewhere (the site "
                "config's \"intrinsics\", or --intrinsics fx,fy,cx,cy)");
  const double fps = options.fps.value_or(30.0);
  if (!(std::isfinite(fps) && fps > 0 && fps <= kMaxFps))
    throw Error("source '" + depth_png.string() + "': fps must be a number in (0, 1000], got " +
                std::to_string(fps));
  FolderCamera camera;
  std::string serial, number;
  if (parse_name(depth_png.filename().string(), "depth.", serial, number))
    for (FolderCamera& c : list_folder_cameras(depth_png.parent_path()))
      if (c.serial == serial) camera = std::move(c);
  if (camera.depth.empty()) {  // any other PNG: one still frame without color
    camera.serial = depth_png.stem().string();
    camera.depth = {depth_png};
    camera.color = {fs::path()};
  }
  CameraCalibration calibration;
  calibration.depth = *options.intrinsics;
  calibration.world_from_camera = options.world_from_camera.value_or(RigidTransform::identity());
  if (camera.depth.size() == 1) {  // decoded once: a still camera
    auto still = open_still_source(camera.depth[0], camera.color[0], calibration, fps,
                                   options.nominal_color);
    const Intrinsics& k = still->calibration().depth;
    check_size(calibration.depth, k.width, k.height, camera.depth[0]);
    return still;
  }
  const DepthImage first = first_readable_depth(camera);
  check_size(calibration.depth, first.width, first.height, depth_png);
  calibration.depth.width = first.width;
  calibration.depth.height = first.height;
  return std::make_unique<FolderSource>(std::move(camera), std::move(calibration), fps);
}

}  // namespace volcast
