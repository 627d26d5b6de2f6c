#pragma once
// The camera poses of a site config, the JSON file `volcast serve --config FILE` reads:
//
//   {"cameras": [{"source": ..., "world_from_camera": {"translation_m": [x, y, z],
//                                                       "rotation_deg": [rx, ry, rz]}}, ...]}
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
#include <vector>

#include "volcast/core/calibration.hpp"

namespace volcast {

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
