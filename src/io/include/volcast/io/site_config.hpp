#pragma once
// The site config, the JSON file `volcast serve --config FILE` reads, `volcast calibrate` writes
// and the desktop viewer's Save updates (poses only):
//
//   {"cameras": [
//     {"source": "cams/depth.000123102712-0001.png",       // required (read_site_config)
//      "name": "000123102712",                             // optional, 1..64 characters
//      "intrinsics": {"width": 640, "height": 576, "fx": ..., "fy": ..., "cx": ..., "cy": ...,
//                     "k1": ..., ..., "metric_radius": ...},   // optional
//      "world_from_camera": {"translation_m": [x, y, z], "rotation_deg": [rx, ry, rz]},  // opt.
//      "registration": {"method": "target", "feature_rms_mm": 0.8, "overlap_rms_mm": 6.1},  // opt.
//      "filters": {...}},                                  // optional, serve's per-camera filters
//     ...]}
//
// "source": an Azure Kinect recording (.mkv), an image-sequence folder, a depth PNG or a live
// camera URL k4a://INDEX-or-SERIAL?... (volcast/capture/k4a_device.hpp; kept as it is)
// (volcast/capture/source.hpp open_source). It is kept as written. A relative path is resolved by
// resolve_site_source: against the working directory if it exists there, else against the config
// file's folder (calibrate writes paths relative to that folder, so a config and its data can be
// moved together).
//
// "intrinsics" (for sources without their own: image sequences without intrinsics.json, depth
// PNGs) is either the pinhole string "fx,fy,cx,cy" or an object with the depth camera's lens model
// (volcast/core/calibration.hpp Intrinsics, pixels, Brown-Conrady as the Azure Kinect SDK): "fx",
// "fy", "cx", "cy" (required) and optionally "width", "height" (integers 1..8192: the image the
// model is for; a depth PNG or image sequence of another size refuses it), "k1".."k6", "p1", "p2",
// "codx", "cody", "metric_radius" (missing = 0). Every value must be a finite number, fx and fy
// positive, metric_radius >= 0 (0 = unlimited); any other key is an error.
//
// "registration" says how the pose was found (informational; serve ignores it): "method" (a
// string, e.g. "target", "targetless", "start + ICP"), "feature_rms_mm" and "overlap_rms_mm"
// (residuals in millimetres; a missing one was not measured). Other keys in it are ignored.
//
// "filters" is kept as JSON text for serve (its keys are serve's, see `volcast serve --help`).
// Other keys of an entry or of the file are ignored by readers and kept by write_site_poses.
//
// "world_from_camera" (optional per camera; either key may be left out, meaning zeros) places the
// camera in the site's world frame: p_world = R * p_camera + t, t in metres, and
//
//   R = Rz(rz) * Ry(ry) * Rx(rx)      (degrees; Rx(a) turns by a about +x, right-handed)
//
// i.e. the camera is turned rx about the world's x axis, then ry about its y axis, then rz about
// its z axis (fixed axes; the same as turning about the camera's own z, then y', then x''). This
// file is the one place that convention lives: serve reads and the desktop viewer's Save writes
// through the functions below.
#include <Eigen/Core>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "volcast/core/calibration.hpp"

namespace volcast {

/// How a camera's pose was found (the "registration" object); -1 = not measured.
struct SiteRegistration {
  std::string method;          ///< e.g. "target", "targetless", "start + ICP"
  double feature_rms_mm = -1;  ///< RMS of the target's sphere centres after the solve, mm
  double overlap_rms_mm = -1;  ///< RMS point-to-plane distance over the overlap, mm
};

/// One entry of the "cameras" list.
struct SiteCamera {
  /// "source" as written; open it through resolve_site_source.
  std::string source;
  /// "name"; empty = none given (serve calls it "camera N", N = its index).
  std::string name;
  /// "intrinsics": a pinhole string reads as fx, fy, cx, cy with width = height = 0 (unknown);
  /// an object as given (width/height 0 when left out).
  std::optional<Intrinsics> intrinsics;
  /// "world_from_camera"; nullopt = not placed (serve uses the identity).
  std::optional<RigidTransform> world_from_camera;
  /// "registration" (informational).
  std::optional<SiteRegistration> registration;
  /// The entry's "filters" value as JSON text (compact), empty if it has none.
  std::string filters_json;
};

/// Reads every entry of `file`. Throws Error naming the file when it cannot be read or is not
/// {"cameras": [...]}, and naming the file, camera index and key when an entry is malformed: not
/// an object, no "source" string, a "name" that is not 1..64 characters, bad "intrinsics" (see
/// above), a malformed "world_from_camera" (as read_site_poses) or "registration" (not an
/// object, "method" not a string, a residual not a finite number >= 0).
std::vector<SiteCamera> read_site_config(const std::filesystem::path& file);

/// Writes a whole site config holding `cameras` (replacing `file`): keys in the order above;
/// "name", "intrinsics", "world_from_camera", "registration", "filters" only when set, a
/// registration residual only when >= 0; intrinsics with all lens keys, "width"/"height" when
/// > 0. Written to a temporary file beside it, then renamed over it. Throws Error naming the file
/// when it cannot be written, and naming the file, camera and key (as read_site_config would)
/// when an entry would not read back: an empty source, a name over 64 characters, bad intrinsics,
/// a non-finite pose or residual, filters_json that is not a JSON object; nothing is written then.
void write_site_config(const std::filesystem::path& file, std::span<const SiteCamera> cameras);

/// Where serve opens a camera's "source" from: `source` itself when absolute or when it exists
/// relative to the working directory, else `config_file`'s folder / `source`.
std::filesystem::path resolve_site_source(const std::string& source,
                                          const std::filesystem::path& config_file);

/// R = Rz(rz) * Ry(ry) * Rx(rx) of rotation_deg = (rx, ry, rz), degrees.
Eigen::Matrix3d rotation_from_degrees(const Eigen::Vector3d& rotation_deg);
/// The angles (rx, ry, rz) in degrees with rotation_from_degrees(angles) == `rotation` (a rotation
/// matrix): ry in [-90, 90], rx and rz in [-180, 180]; at ry = +-90 (gimbal lock) rx is 0.
Eigen::Vector3d degrees_from_rotation(const Eigen::Matrix3d& rotation);

/// The world_from_camera of each entry of `file`'s "cameras" list (index = camera), nullopt for an
/// entry without "world_from_camera". Throws Error naming the file when it cannot be read or is
/// not {"cameras": [...]}, and naming the file, camera index and key when a pose is malformed (not
/// an object, an unknown key, not 3 finite numbers).
std::vector<std::optional<RigidTransform>> read_site_poses(const std::filesystem::path& file);

/// Writes `world_from_camera` (index = camera) into `file` as each camera's "world_from_camera":
/// an existing file's "cameras"[i] entries are updated in place, keeping their other keys and the
/// order of keys; cameras beyond its list are appended as entries holding only the pose (serve
/// needs a "source" added to them). A missing file is created holding only the poses. Written to a
/// temporary file beside it, then renamed over it. Throws Error naming the file when it exists but
/// is not a JSON object with an optional "cameras" list of objects, or cannot be written.
void write_site_poses(const std::filesystem::path& file,
                      std::span<const RigidTransform> world_from_camera);

}  // namespace volcast
