#pragma once
// Azure Kinect recordings written by k4arecorder (Matroska): tracks DEPTH (fourcc b16g, 16-bit
// big-endian millimetres), COLOR (MJPG or BGRA), IR, IMU, and a `calibration.json` attachment.
// Read through libavformat. Spec: Azure Kinect "Recording file format" documentation.
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "volcast/capture/k4a_calibration.hpp"
#include "volcast/capture/source.hpp"

namespace volcast {

/// What `volcast info` reports about a recording.
struct K4aRecordingInfo {
  struct Stream {
    int index = 0;
    std::string title;  ///< Matroska track name: COLOR, DEPTH, IR, IMU, or an attachment's file
    std::string codec;  ///< codec name or fourcc
    int width = 0, height = 0;
  };
  std::vector<Stream> streams;
  std::string depth_mode;  ///< e.g. NFOV_UNBINNED
  /// e.g. MJPG_720P; COLOR_ON_DEPTH for a file whose only color is that custom track (JPEG
  /// registered to depth, depth size: volcast export); empty without color.
  std::string color_mode;
  int depth_frames = 0;  ///< depth frames in the file (counted by reading every packet)
  int color_frames = 0;
  double duration_s = 0;
  double fps = 0;               ///< the recording's frame rate
  Intrinsics depth_intrinsics;  ///< derived for the depth mode, pixels
  Intrinsics color_intrinsics;  ///< derived for the color resolution, pixels (width 0 if none)
  RigidTransform color_from_depth;
};

/// Reads a recording's layout and derived intrinsics, without decoding frames (a depth frame of
/// the wrong size is counted; check_frames in source.hpp finds it). Throws Error if the file is
/// missing, is not Matroska, has no DEPTH track or no calibration attachment, or is truncated
/// mid-packet.
K4aRecordingInfo probe_k4a_recording(const std::filesystem::path& path);

/// A looping FrameSource over a recording: depth as written, color decoded (libjpeg-turbo) and
/// registered to depth, so each frame is depth WxH plus BGRA WxH of the depth mode -- or empty
/// color (0 x 0) where the recording has no color track of a supported format (MJPG, BGRA) or a
/// capture has no color frame. Without a COLOR track, a COLOR_ON_DEPTH custom track (MJPG at
/// the depth size, already registered: what volcast export writes) is decoded as is. next() throws
/// Error naming the recording and the frame's time for a depth frame of the wrong size or a color
/// frame that does not decode, and moves on to the next capture.
std::unique_ptr<FrameSource> open_k4a_recording(const std::filesystem::path& path,
                                                const SourceOptions& options);

}  // namespace volcast
