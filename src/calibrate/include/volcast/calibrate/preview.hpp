#pragma once
// The picture `volcast calibrate --preview` writes: the registered cameras' points from above and
// from the side, each camera tinted its own color, so a person sees at a glance whether the room
// is one room.
#include <filesystem>
#include <span>

#include "volcast/core/calibration.hpp"
#include "volcast/core/frame.hpp"

namespace volcast {

/// Renders `frames` (camera i placed by cameras[i].world_from_camera) orthographically from above
/// (left half) and from the side (right half) into one PNG of 1920 x 720. `room_aligned`: the
/// world's +y is up (room frame); otherwise the first camera's -y is taken as up. Tints: camera 0
/// red, 1 green, 2 blue, 3 yellow, then magenta, cyan, orange, white. Throws Error when rendering
/// (EGL) or writing fails.
void write_calibration_preview(const std::filesystem::path& png,
                               std::span<const CameraCalibration> cameras,
                               std::span<const CameraFrame> frames, bool room_aligned);

}  // namespace volcast
