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
/// either, a nominal pinhole of 70 degrees horizontal field of view, with a loud warning.
/// Throws Error if DIR/depth holds no PNG, or intrinsics.json is malformed.
std::unique_ptr<FrameSource> open_image_sequence(const std::filesystem::path& dir,
                                                 const SourceOptions& options);

}  // namespace volcast
