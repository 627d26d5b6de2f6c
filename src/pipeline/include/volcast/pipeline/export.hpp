#pragma once
// Exporting a recording (volcast/record/recording.hpp) for other tools: point clouds as binary PLY
// (Open3D's writer), images as PNG, and Azure Kinect recordings (.mkv, libmatroska).
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>

namespace volcast {

struct ExportOptions {
  std::filesystem::path ply_dir;  ///< one binary PLY per frame set and camera; empty: none
  std::filesystem::path png_dir;  ///< depth (16-bit, mm) and color PNGs; empty: none
  /// Azure Kinect-style Matroska (below); several cameras: FILE's stem + "-camera-C.mkv" each.
  std::filesystem::path mkv;
  double from_s = 0, to_s = -1;  ///< the part exported: seconds after the first frame set
  /// Called after each frame set with (done, total).
  std::function<void(size_t, size_t)> progress;
};

struct ExportReport {
  size_t frame_sets = 0;      ///< exported
  size_t files = 0;           ///< written
  uint64_t points = 0;        ///< in all PLY files
  uint64_t valid_pixels = 0;  ///< depth pixels != 0 in the exported frames
  uint64_t skipped = 0;       ///< frame sets that could not be decoded (named in warnings)
};

/// Decodes the recording at `path` and writes, for frame set k (0-based within the range) and
/// camera c:
///   PLY: ply_dir/frame-KKKKKK-camera-C.ply -- binary little-endian, x y z (double, metres, the
///     site's world frame: world_from_camera of the recording's calibration) and red green blue
///     (uchar; gray 160 where the pixel had no color), one vertex per valid depth pixel that has a
///     lens ray (CloudBuilder).
///   PNG: png_dir/camera-C/depth/KKKKKK.png (16-bit gray, mm, 0 = invalid) and
///     png_dir/camera-C/color/KKKKKK.png (RGB, registered to depth; absent where the frame had no
///     color), plus png_dir/camera-C/intrinsics.json: an image-sequence folder `volcast serve
///     --source` reads back.
///   MKV (cameras whose depth is the size of an Azure Kinect depth mode): k4arecorder's Matroska
///     layout written with libmatroska (k4a_mkv_writer.hpp, which spells out the file): a "DEPTH"
///     track of b16g depth (V_MS/VFW/FOURCC), the K4A tags, a calibration.json attachment made
///     from the camera's intrinsics (k4a_calibration_json), and the color registered to depth as a
///     k4arecord custom track "COLOR_ON_DEPTH" (MJPG, depth size): a k4arecorder COLOR track holds
///     the color camera's own image, which a stream does not carry. Timestamps are the frames'
///     device times in microseconds. `volcast info`, `serve --source` and FFmpeg read it back; the
///     layout is the one the Azure Kinect SDK's playback reads (that SDK is not in Debian:
///     untested).
/// Every file written has mode 0600 (it shows the OR: volcast/core/private_file.hpp). Frame sets
/// are selected by the recording's playback timeline (recording.hpp: absurd gaps clamped).
/// Throws Error if the recording cannot be opened, the range holds no frame sets or a file cannot
/// be written (naming it); a frame set that cannot be decoded is skipped with a warning.
ExportReport export_recording(const std::filesystem::path& path, const ExportOptions& options);

}  // namespace volcast
