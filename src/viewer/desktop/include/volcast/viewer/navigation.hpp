#pragma once
// Desktop navigation as pure functions of a ViewCamera (no window, no OpenGL), world frame, metres.
// Orbit turns the eye about the pivot (the camera's target) and zooms toward it; fly turns the line
// of sight about the eye and moves eye and pivot together. The camera's `up` is the world's up for
// navigation and never changes: yaw turns about it, and pitch stops kMinPitchGapDeg short of it
// (and of -up), so look_at() always has a direction.
#include <Eigen/Core>

#include "volcast/render/view.hpp"

namespace volcast {

/// How close (degrees) the line of sight may come to `up` or `-up`.
inline constexpr float kMinPitchGapDeg = 5;

/// Orbit (left drag): turns the eye about the target, `yaw_deg` about `up` (right-handed) and then
/// `pitch_deg` about the view's right axis (positive raises the eye toward `up`). The distance to
/// the target is kept.
ViewCamera orbit(const ViewCamera& camera, float yaw_deg, float pitch_deg);

/// Zoom (wheel): moves the eye along the line of sight so that its distance to the target becomes
/// distance * 0.85^steps (positive steps: closer), at least 0.05 m and at most 1000 m.
ViewCamera zoom(const ViewCamera& camera, float steps);

/// Fly look (right drag): turns the line of sight about the eye, `yaw_deg` about `up`
/// (right-handed: positive turns left) and `pitch_deg` about the view's right axis (positive looks
/// up). The eye and the distance to the target are kept.
ViewCamera look(const ViewCamera& camera, float yaw_deg, float pitch_deg);

/// Fly move (WASD / QE): moves eye and target together by right_up_forward_m metres along the
/// view's right axis, `up`, and the line of sight projected off `up` (level, like walking).
ViewCamera fly(const ViewCamera& camera, const Eigen::Vector3f& right_up_forward_m);

}  // namespace volcast
