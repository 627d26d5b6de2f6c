#pragma once
// Image-sequence folders: DIR/depth/*.png (16-bit, millimetres, 0 = invalid) and optionally
// DIR/color/*.{jpg,png} registered to depth (same size, matched by file stem), plus an optional
// DIR/intrinsics.json:
//   {"fx": 460, "fy": 460, "cx": 320, "cy": 180,          (pixels, required)
//    "k1".."k6", "p1", "p2": Brown-Conrady terms           (optional, default 0)
//    "fps": 30,                                            (optional)
//    "world_from_camera": {"rotation": [9 row-major], "translation": [x, y, z] metres}} (optional)
#include <filesystem>
#include <memory>

#include "volcast/capture/source.hpp"

namespace volcast {

/// Opens an image-sequence folder. Without intrinsics.json, options.intrinsics is used; without
/// either, a nominal pinhole of 70 degrees horizontal field of view, with a loud warning. The
/// first readable depth PNG sets the size every frame must have. A depth frame without a color
/// file of its stem has an empty color image (no color/ folder at all: depth only).
/// Throws Error naming the file and field if DIR/depth holds no PNG or none that can be read,
/// intrinsics.json is malformed, or a value is out of range: fps (there or in options) must be
/// finite and in (0, 1000]; intrinsics finite with fx, fy > 0; world_from_camera finite.
/// next() throws Error naming the file for a frame that cannot be read (corrupt, truncated, not
/// 16-bit, another size, a color file that does not decode or is not registered) and moves on:
/// the following call reads the following frame.
std::unique_ptr<FrameSource> open_image_sequence(const std::filesystem::path& dir,
                                                 const SourceOptions& options);

}  // namespace volcast
