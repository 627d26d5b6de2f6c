#pragma once
// Azure Kinect factory calibration (the `calibration.json` that k4arecorder attaches) and the
// derivation of a mode's intrinsics exactly as the Azure Kinect SDK does
// (transformation_get_mode_specific_camera_calibration in the SDK's transformation.c).
#include <optional>
#include <string>
#include <string_view>

#include "volcast/core/calibration.hpp"

namespace volcast {

/// One camera of the factory calibration, intrinsics normalised to its native sensor
/// (depth 1024x1024, color 4096x3072): fx, fy, cx, cy are fractions of the sensor size.
struct K4aSensorCalibration {
  Intrinsics normalized;  ///< width/height = native sensor size; fx..cy normalised
  /// camera_from_depth: the JSON's Rt (metres) maps depth-camera points into this camera.
  RigidTransform camera_from_depth;
};

struct K4aCalibration {
  K4aSensorCalibration depth;
  K4aSensorCalibration color;
};

/// Parses the calibration JSON text. The 14 ModelParameters are, in order:
/// cx, cy, fx, fy, k1, k2, k3, k4, k5, k6, codx, cody, p2, p1 (the SDK's parameter struct).
/// Throws Error naming the missing or malformed field.
K4aCalibration parse_k4a_calibration(std::string_view json_text);

/// Depth modes of the Azure Kinect, named as in k4arecorder's K4A_DEPTH_MODE tag.
enum class K4aDepthMode {
  kNfov2x2Binned,
  kNfovUnbinned,
  kWfov2x2Binned,
  kWfovUnbinned,
  kPassiveIr
};

/// Parses "NFOV_UNBINNED", "NFOV_2X2BINNED", "WFOV_2X2BINNED", "WFOV_UNBINNED", "PASSIVE_IR".
K4aDepthMode parse_k4a_depth_mode(std::string_view name);

/// Intrinsics of a depth mode in pixels: the native model is scaled to the mode's binned
/// resolution (1024 or 512), shifted by its crop offset (NFOV: 192,180 unbinned / 96,90 binned;
/// WFOV: 0,0) and by -0.5 px (pixel-centred coordinates). E.g. NFOV unbinned: 640x576,
/// cx = cx_n*1024 - 192 - 0.5.
Intrinsics k4a_depth_mode_intrinsics(const K4aSensorCalibration& depth, K4aDepthMode mode);

/// Intrinsics of a color resolution (width x height, e.g. 1280x720) in pixels: the 4096x3072
/// native model is scaled to width x width*3/4 and cropped vertically to height, centred.
/// Throws Error for a resolution that is not an Azure Kinect color mode.
Intrinsics k4a_color_mode_intrinsics(const K4aSensorCalibration& color, int width, int height);

/// The depth mode whose images are `width` x `height` (640x576 NFOV unbinned, 320x288 NFOV
/// binned, 512x512 WFOV binned, 1024x1024 WFOV unbinned), or nullopt.
std::optional<K4aDepthMode> k4a_depth_mode_of_size(int width, int height);

/// The name k4arecorder's K4A_DEPTH_MODE tag gives `mode` ("NFOV_UNBINNED", ...).
std::string k4a_depth_mode_name(K4aDepthMode mode);

/// A factory calibration JSON (the layout parse_k4a_calibration reads) whose depth camera yields
/// `depth` (pixel intrinsics of `mode`, as k4a_depth_mode_intrinsics derives them) in `mode`: the
/// inverse of that derivation. The color camera is written as a copy of the depth camera (identity
/// Rt) -- for exports of streams whose color is already registered to depth, which keep no color
/// camera calibration. Throws Error if `depth` is not of `mode`'s size.
std::string k4a_calibration_json(const Intrinsics& depth, K4aDepthMode mode);

}  // namespace volcast
