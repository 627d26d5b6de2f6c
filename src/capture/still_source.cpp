#include "volcast/capture/still_source.hpp"

#include <algorithm>
#include <cctype>
#include <fstream>
#include <iterator>
#include <vector>

#include "volcast/capture/registration.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/image_io.hpp"
#include "volcast/core/jpeg.hpp"

namespace volcast {
namespace {

class StillSource final : public FrameSource {
 public:
  StillSource(CameraFrame frame, CameraCalibration calibration, double fps, std::string what)
      : frame_(std::move(frame)),
        calibration_(std::move(calibration)),
        fps_(fps),
        description_(std::move(what)) {}
  const CameraCalibration& calibration() const override { return calibration_; }
  double fps() const override { return fps_; }
  int frame_count() const override { return 1; }
  int color_frame_count() const override { return frame_.color.empty() ? 0 : 1; }
  // A new copy of the frame every time, as a camera delivers new buffers (copy assignment keeps
  // the capacity of a recycled `out`: no allocation).
  void next(CameraFrame& out) override {
    out.depth = frame_.depth;
    out.color = frame_.color;
    out.device_timestamp_us = static_cast<int64_t>(static_cast<double>(count_++) * 1e6 / fps_);
  }
  std::string description() const override { return description_; }

 private:
  CameraFrame frame_;
  CameraCalibration calibration_;
  double fps_;
  std::string description_;
  int64_t count_ = 0;
};

}  // namespace

ColorImage resample_nearest(const ColorImage& in, int width, int height) {
  ColorImage out(width, height);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const int sx = static_cast<int>((static_cast<int64_t>(x) * in.width) / width);
      const int sy = static_cast<int>((static_cast<int64_t>(y) * in.height) / height);
      const uint8_t* p = in.pixel(sx, sy);
      std::copy(p, p + 4, out.pixel(x, y));
    }
  return out;
}

ColorImage read_color_image(const std::filesystem::path& file) {
  std::string ext = file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext != ".jpg" && ext != ".jpeg") return read_color_png(file);
  std::ifstream in(file, std::ios::binary);
  if (!in) throw Error("cannot read '" + file.string() + "'");
  const std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)),
                                   std::istreambuf_iterator<char>());
  ColorImage out;
  try {
    decode_jpeg(bytes, out);
  } catch (const Error& e) {
    throw Error("'" + file.string() + "': " + e.what());
  }
  return out;
}

std::unique_ptr<FrameSource> open_still_source(
    const std::filesystem::path& depth_png, const std::filesystem::path& color_image,
    CameraCalibration calibration, double fps,
    const std::optional<ColorCalibration>& nominal_color) {
  if (!(fps > 0)) throw Error("still source: fps must be positive");
  CameraFrame frame;
  frame.depth = read_depth_png(depth_png);
  calibration.depth.width = frame.depth.width;
  calibration.depth.height = frame.depth.height;
  if (!color_image.empty()) {
    const ColorImage color = read_color_image(color_image);
    if (nominal_color && color.width == nominal_color->intrinsics.width &&
        color.height == nominal_color->intrinsics.height)
      ColorToDepthRegistration(calibration.depth, nominal_color->intrinsics,
                               nominal_color->color_from_depth)
          .apply(frame.depth, color, frame.color);
    else
      frame.color = color.width == frame.depth.width && color.height == frame.depth.height
                        ? color
                        : resample_nearest(color, frame.depth.width, frame.depth.height);
  }
  return std::make_unique<StillSource>(std::move(frame), std::move(calibration), fps,
                                       "still " + depth_png.string());
}

}  // namespace volcast
