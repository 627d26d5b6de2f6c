#pragma once
// The desktop panel's per-camera registration sliders (the paper's in-game sliders): a correction
// on top of the world_from_camera the server sent, saved into the site config by Save.
#include <Eigen/Core>

#include "volcast/core/calibration.hpp"

namespace volcast {

/// One camera's sliders. Rotation angles follow the site config's convention (Rz * Ry * Rx, see
/// volcast/io/site_config.hpp).
struct PoseSliders {
  Eigen::Vector3f translation_mm = Eigen::Vector3f::Zero();  ///< along world x, y, z; panel +-2000
  Eigen::Vector3f rotation_deg = Eigen::Vector3f::Zero();    ///< about world x, y, z; panel +-180
};

/// The camera's pose after the sliders: it turns in place (about world axes through its own
/// origin) and moves along the world axes:
///   rotation = rotation_from_degrees(rotation_deg) * received.rotation
///   translation = received.translation + translation_mm / 1000.
/// Zero sliders give `received` back exactly.
RigidTransform apply_sliders(const RigidTransform& received_world_from_camera,
                             const PoseSliders& sliders);

}  // namespace volcast
