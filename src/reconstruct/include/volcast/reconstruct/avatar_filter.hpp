#pragma once
// Avatar filters (Fischer et al., "Evaluation of Point Cloud Streaming and Rendering for VR-based
// Telepresence in the OR"): a participant's own RGB-D camera sees the whole room behind them, so
// receivers keep only the points near the participant's head (the paper's filter around the
// centre of mass), and the participant's own view hides the headset it wears, whose points would
// sit right in front of its eyes. The same test runs on the CPU (here) and in the splat
// renderer's vertex shaders (SplatRenderer::set_avatar_filter), so both drop the same points.
#include <Eigen/Core>
#include <optional>

#include "volcast/core/calibration.hpp"
#include "volcast/reconstruct/point_cloud.hpp"

namespace volcast {

/// Keeps only points within `radius_m` metres (inclusive) of `center` (world frame, metres).
struct KeepSphere {
  Eigen::Vector3f center = Eigen::Vector3f::Zero();
  float radius_m = 0.6f;  ///< head, shoulders and hands of a seated or standing person
};

/// Hides points inside a box (inclusive) around a headset. `world_from_headset` places the
/// headset: origin between the eyes, x right, y up, z backwards (OpenXR's view space);
/// `half_extent_m` is the box's half size along those axes, in metres. The default covers a
/// Quest-class headset and the face and hair behind it.
struct HideBox {
  RigidTransform world_from_headset;
  Eigen::Vector3f half_extent_m{0.12f, 0.10f, 0.14f};
};

/// Either filter, both (a point must pass each), or none (every point kept).
struct AvatarFilter {
  std::optional<KeepSphere> keep;
  std::optional<HideBox> hide;
};

/// Whether `filter` keeps a point at `p_world` (world frame, metres). Throws nothing.
bool avatar_filter_keeps(const AvatarFilter& filter, const Eigen::Vector3f& p_world);

/// Removes the points of `cloud` (world frame) that `filter` does not keep, in place, keeping
/// the others in order; allocates nothing. Returns how many were removed.
size_t apply_avatar_filter(const AvatarFilter& filter, PointCloud& cloud);

}  // namespace volcast
