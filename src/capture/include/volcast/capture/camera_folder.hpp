#pragma once
// A camera folder: several cameras' frames side by side in one folder, one camera per serial
// number, as ../shared/data/k4a-4cam-nfov (four Azure Kinects) holds them:
//
//   depth.<serial>-<n>.png   frame <n> (digits) of camera <serial>: 16-bit grayscale PNG,
//                            millimetres, 0 = invalid
//   rgb.<serial>-<n>.png     its color (or .jpg/.jpeg); optional. NOT registered to depth (such
//                            sets carry no depth-to-color extrinsics): it is resampled to the
//                            depth grid by nearest neighbour, so colors sit only roughly on the
//                            surfaces -- fine for streaming, not for looking closely
//
// The PNGs carry no intrinsics: they come from SourceOptions::intrinsics (a site config's
// "intrinsics", volcast/io/site_config.hpp, e.g. the Azure Kinect's full NFOV lens model).
// Such a folder is not a source itself (open_source refuses it, naming its cameras): each camera
// is opened through one of its depth PNGs.
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "volcast/capture/source.hpp"

namespace volcast {

/// One camera of a camera folder: its frames in name order.
struct FolderCamera {
  std::string serial;
  std::vector<std::filesystem::path> depth;  ///< depth.<serial>-<n>.png, in name order
  /// Same length as `depth`: frame i's rgb.<serial>-<n>.{png,jpg,jpeg}, or an empty path.
  std::vector<std::filesystem::path> color;
};

/// The cameras of `dir`, sorted by serial; empty when it holds no depth.<serial>-<n>.png (or is
/// not a readable folder). Reads names only, no image.
std::vector<FolderCamera> list_folder_cameras(const std::filesystem::path& dir);

/// Opens the camera of `depth_png`, the source open_source makes of a `.png` file. A
/// depth.<serial>-<n>.png (any frame of it) plays every depth.<serial>-*.png of its folder in name
/// order from the first, one frame each, looping, with the matching color where there is one. Any
/// other PNG is one still depth frame without color. Frame rate options.fps, else 30 fps (device
/// timestamps advance by 1/fps per frame); intrinsics options.intrinsics (width and height set
/// from the PNGs); world_from_camera options.world_from_camera, else the identity. A single-frame
/// camera is decoded once, here; a longer one frame by frame in next().
/// Throws Error naming the file when options.intrinsics is missing (a PNG needs them, e.g. from
/// the site config), when their width/height (if given) differ from the PNG's, when no depth
/// frame can be read, or when fps is not in (0, 1000]. next() throws Error naming the file for a
/// corrupt PNG or a frame whose size differs from the camera's first (the frame is skipped).
std::unique_ptr<FrameSource> open_folder_camera(const std::filesystem::path& depth_png,
                                                const SourceOptions& options);

}  // namespace volcast
