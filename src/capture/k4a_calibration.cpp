#include "volcast/capture/k4a_calibration.hpp"

#include <nlohmann/json.hpp>

#include "volcast/core/error.hpp"

namespace volcast {
namespace {

using nlohmann::json;

K4aSensorCalibration parse_camera(const json& cam, const char* purpose) {
  K4aSensorCalibration out;
  const json& params = cam.at("Intrinsics").at("ModelParameters");
  if (!params.is_array() || params.size() < 14)
    throw Error(std::string("k4a calibration: ") + purpose +
                " camera has fewer than 14 ModelParameters");
  auto p = [&](size_t i) { return params.at(i).get<double>(); };
  Intrinsics& k = out.normalized;
  k.cx = p(0), k.cy = p(1), k.fx = p(2), k.fy = p(3);
  k.k1 = p(4), k.k2 = p(5), k.k3 = p(6), k.k4 = p(7), k.k5 = p(8), k.k6 = p(9);
  k.codx = p(10), k.cody = p(11), k.p2 = p(12), k.p1 = p(13);
  k.metric_radius = cam.value("MetricRadius", 0.0);
  k.width = cam.at("SensorWidth").get<int>();
  k.height = cam.at("SensorHeight").get<int>();
  const json& rt = cam.at("Rt");
  const json& r = rt.at("Rotation");
  const json& t = rt.at("Translation");
  if (r.size() != 9 || t.size() != 3)
    throw Error(std::string("k4a calibration: ") + purpose + " camera Rt has wrong shape");
  for (int i = 0; i < 9; ++i) out.camera_from_depth.rotation(i / 3, i % 3) = r[i].get<double>();
  for (int i = 0; i < 3; ++i) out.camera_from_depth.translation[i] = t[i].get<double>();
  return out;
}

}  // namespace

K4aCalibration parse_k4a_calibration(std::string_view json_text) {
  json doc = json::parse(json_text, nullptr, false);
  if (doc.is_discarded()) throw Error("k4a calibration: not valid JSON");
  try {
    K4aCalibration out;
    bool have_depth = false, have_color = false;
    for (const json& cam : doc.at("CalibrationInformation").at("Cameras")) {
      const std::string purpose = cam.value("Purpose", "");
      if (purpose == "CALIBRATION_CameraPurposeDepth") {
        out.depth = parse_camera(cam, "depth");
        have_depth = true;
      } else if (purpose == "CALIBRATION_CameraPurposePhotoVideo") {
        out.color = parse_camera(cam, "color");
        have_color = true;
      }
    }
    if (!have_depth) throw Error("k4a calibration: no depth camera (CameraPurposeDepth)");
    if (!have_color) throw Error("k4a calibration: no color camera (CameraPurposePhotoVideo)");
    return out;
  } catch (const json::exception& e) {
    throw Error(std::string("k4a calibration: missing or malformed field: ") + e.what());
  }
}

K4aDepthMode parse_k4a_depth_mode(std::string_view name) {
  if (name == "NFOV_UNBINNED") return K4aDepthMode::kNfovUnbinned;
  if (name == "NFOV_2X2BINNED") return K4aDepthMode::kNfov2x2Binned;
  if (name == "WFOV_UNBINNED") return K4aDepthMode::kWfovUnbinned;
  if (name == "WFOV_2X2BINNED") return K4aDepthMode::kWfov2x2Binned;
  if (name == "PASSIVE_IR") return K4aDepthMode::kPassiveIr;
  throw Error("unknown Azure Kinect depth mode '" + std::string(name) + "'");
}

namespace {

// The SDK's k4a_camera_calibration_mode_info_t and its use with pixelized_zero_centered_output.
Intrinsics mode_intrinsics(const Intrinsics& n, int binned_w, int binned_h, int crop_x, int crop_y,
                           int out_w, int out_h) {
  Intrinsics k = n;
  k.width = out_w;
  k.height = out_h;
  k.fx = n.fx * binned_w;
  k.fy = n.fy * binned_h;
  k.cx = n.cx * binned_w - crop_x - 0.5;
  k.cy = n.cy * binned_h - crop_y - 0.5;
  return k;
}

// A depth mode's image: the native 1024x1024 model binned to `binned`, cropped at (crop_x,
// crop_y) to width x height (the SDK's mode info). One table for the intrinsics, their inverse
// and the mode of an image size.
struct DepthModeGeometry {
  K4aDepthMode mode;
  int binned, crop_x, crop_y, width, height;
};
constexpr DepthModeGeometry kDepthModes[] = {
    {K4aDepthMode::kNfov2x2Binned, 512, 96, 90, 320, 288},
    {K4aDepthMode::kNfovUnbinned, 1024, 192, 180, 640, 576},
    {K4aDepthMode::kWfov2x2Binned, 512, 0, 0, 512, 512},
    {K4aDepthMode::kWfovUnbinned, 1024, 0, 0, 1024, 1024},
};

const DepthModeGeometry& geometry_of(K4aDepthMode mode) {
  // Passive IR images are the full unbinned sensor.
  const K4aDepthMode m = mode == K4aDepthMode::kPassiveIr ? K4aDepthMode::kWfovUnbinned : mode;
  for (const DepthModeGeometry& g : kDepthModes)
    if (g.mode == m) return g;
  throw Error("unknown Azure Kinect depth mode");
}

}  // namespace

Intrinsics k4a_depth_mode_intrinsics(const K4aSensorCalibration& depth, K4aDepthMode mode) {
  const DepthModeGeometry& g = geometry_of(mode);
  return mode_intrinsics(depth.normalized, g.binned, g.binned, g.crop_x, g.crop_y, g.width,
                         g.height);
}

Intrinsics k4a_color_mode_intrinsics(const K4aSensorCalibration& color, int width, int height) {
  // 720P, 1080P, 1440P, 2160P are 16:9 crops of a 4:3 binned image; 1536P and 3072P are 4:3.
  static constexpr int kModes[][2] = {{1280, 720},  {1920, 1080}, {2560, 1440},
                                      {2048, 1536}, {3840, 2160}, {4096, 3072}};
  bool known = false;
  for (const auto& m : kModes) known = known || (m[0] == width && m[1] == height);
  if (!known)
    throw Error("color resolution " + std::to_string(width) + "x" + std::to_string(height) +
                " is not an Azure Kinect color mode");
  const int binned_h = width * 3 / 4;
  return mode_intrinsics(color.normalized, width, binned_h, 0, (binned_h - height) / 2, width,
                         height);
}

std::optional<K4aDepthMode> k4a_depth_mode_of_size(int width, int height) {
  for (const DepthModeGeometry& g : kDepthModes)
    if (g.width == width && g.height == height) return g.mode;
  return std::nullopt;
}

std::string k4a_depth_mode_name(K4aDepthMode mode) {
  switch (mode) {
    case K4aDepthMode::kNfov2x2Binned:
      return "NFOV_2X2BINNED";
    case K4aDepthMode::kNfovUnbinned:
      return "NFOV_UNBINNED";
    case K4aDepthMode::kWfov2x2Binned:
      return "WFOV_2X2BINNED";
    case K4aDepthMode::kWfovUnbinned:
      return "WFOV_UNBINNED";
    case K4aDepthMode::kPassiveIr:
      return "PASSIVE_IR";
  }
  return "OFF";
}

std::string k4a_calibration_json(const Intrinsics& depth, K4aDepthMode mode) {
  // The mode's binned size and crop (k4a_depth_mode_intrinsics), undone.
  const DepthModeGeometry& g = geometry_of(mode);
  const int crop_x = g.crop_x, crop_y = g.crop_y;
  const auto size = k4a_depth_mode_of_size(depth.width, depth.height);
  if (!size || (*size != mode && mode != K4aDepthMode::kPassiveIr))
    throw Error("k4a calibration: " + std::to_string(depth.width) + "x" +
                std::to_string(depth.height) + " is not the size of depth mode " +
                k4a_depth_mode_name(mode));
  const double b = g.binned;
  const json params = {(depth.cx + crop_x + 0.5) / b,
                       (depth.cy + crop_y + 0.5) / b,
                       depth.fx / b,
                       depth.fy / b,
                       depth.k1,
                       depth.k2,
                       depth.k3,
                       depth.k4,
                       depth.k5,
                       depth.k6,
                       depth.codx,
                       depth.cody,
                       depth.p2,
                       depth.p1};
  const auto camera = [&](const char* purpose, const char* location, int w, int h) {
    return json{{"Location", location},
                {"Purpose", purpose},
                {"MetricRadius", depth.metric_radius},
                {"SensorWidth", w},
                {"SensorHeight", h},
                {"Intrinsics",
                 {{"ModelType", "CALIBRATION_LensDistortionModelBrownConrady"},
                  {"ModelParameterCount", 14},
                  {"ModelParameters", params}}},
                {"Rt", {{"Rotation", {1, 0, 0, 0, 1, 0, 0, 0, 1}}, {"Translation", {0, 0, 0}}}}};
  };
  const json doc = {
      {"CalibrationInformation",
       {{"Cameras",
         {camera("CALIBRATION_CameraPurposeDepth", "CALIBRATION_CameraLocationD0", 1024, 1024),
          camera("CALIBRATION_CameraPurposePhotoVideo", "CALIBRATION_CameraLocationPV0", 4096,
                 3072)}}}}};
  return doc.dump(2);
}

}  // namespace volcast
