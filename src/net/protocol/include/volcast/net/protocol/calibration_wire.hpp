#pragma once
// A camera's calibration as the protocol's Welcome carries it (protocol.hpp 0.2), also the
// session channel's AvatarCamera (session/messages.hpp). Written with the wire codec
// (core/wire.hpp).
#include "volcast/core/calibration.hpp"
#include "volcast/core/wire.hpp"

namespace volcast::protocol {

/// Writes width u16, height u16, the 15 intrinsics fx fy cx cy k1..k6 p1 p2 codx cody
/// metric_radius (f64), rotation (9 f64, row-major) and translation (3 f64, metres) of the pose.
void put_calibration(wire::Writer& w, const CameraCalibration& c);
/// Reads what put_calibration wrote. Checks only what any calibration needs (a non-empty size, a
/// positive focal length, finite numbers, a rotation); the caller bounds the size. Throws Error
/// ("malformed <what>: ...").
CameraCalibration get_calibration(wire::Reader& r);

}  // namespace volcast::protocol
