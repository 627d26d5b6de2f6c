#pragma once
// OpenXR's eye poses and fields of view as Views (view.hpp): pure functions, no runtime, no OpenGL.
//
// Frames: OpenXR locates each eye in a reference space, here called "stage": metres, y up (against
// gravity), x right and -z forward for a user facing the space's -z, origin on the floor (STAGE)
// or at the head's starting position (LOCAL). An eye's view frame is OpenXR's view space, which
// is already View's convention (x right, y up, looking down -z). world_from_stage places the stage
// in the site's world frame (CameraCalibration::world_from_camera's world).
#include <openxr/openxr.h>

#include "volcast/core/calibration.hpp"
#include "volcast/render/view.hpp"

namespace volcast {

/// A pose (orientation quaternion x, y, z, w -- normalised here -- and position, metres) as the
/// rigid transform target_from_pose it describes.
RigidTransform rigid_from_xr(const XrPosef& pose);

/// One eye's View: world_from_view = world_from_stage * stage_from_eye, and clip_from_view =
/// perspective_from_tangents(tan(angleLeft), tan(angleRight), tan(angleUp), tan(angleDown),
/// near_m, far_m) (XrFovf angles in radians, left and down negative for a centred eye). Throws
/// Error as perspective_from_tangents does (e.g. a zero-width field of view).
View xr_eye_view(const RigidTransform& world_from_stage, const XrPosef& stage_from_eye,
                 const XrFovf& fov, float near_m, float far_m);

/// Where the stage sits in the world so that a user standing at its origin with eyes
/// `eye_height_m` above it, looking down -z, sees what `start` shows: the stage point
/// (0, eye_height_m, 0) lands on start.eye, stage +y along start.up, and stage -z along the line
/// of sight made level (orthogonal to up; any level direction if the line of sight is vertical).
RigidTransform world_from_stage(const ViewCamera& start, float eye_height_m);

}  // namespace volcast
