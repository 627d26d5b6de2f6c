#pragma once
// One camera written as an Azure Kinect recording: k4arecorder's Matroska layout (Azure Kinect
// Sensor SDK, src/record/sdk/record.cpp and src/record/internal/matroska_write.cpp), written with
// libmatroska as k4arecorder itself does. The file, as it really is:
//   EBML head: DocType "matroska", DocTypeVersion 2, DocTypeReadVersion 2.
//   Segment (8-byte size field):
//     SeekHead (to Info, Tracks, Attachments, Tags, Cues), in a 1 KiB void reserved up front;
//     Info, in a 256-byte void: TimestampScale 1000 ns (block times are microseconds),
//       MuxingApp "libmatroska-1.7.1", WritingApp "volcast export", Title "Azure Kinect", DateUTC,
//       Duration (µs);
//     Tracks:
//       1 "DEPTH": V_MS/VFW/FOURCC, CodecPrivate a 40-byte little-endian BITMAPINFOHEADER
//         {40, width, height, 1 plane, 16 bits, 'b16g', width*height*2}, DefaultDuration 1e9/fps
//         ns (fps the nearest Azure Kinect rate: 5, 15 or 30), video width x height; each frame
//         width*height big-endian uint16, depth in mm (0 = invalid);
//       2 "COLOR_ON_DEPTH" (only for a camera with color): a k4arecord custom video track (as
//         k4a_record_add_custom_video_track writes one): V_MS/VFW/FOURCC, BITMAPINFOHEADER
//         {40, width, height, 1, 24, 'MJPG', 0}, depth size; each frame a JPEG of the color
//         registered to depth. A k4arecorder COLOR track holds the color camera's own image,
//         which a Volcast stream does not carry, so the file has no COLOR track (color mode OFF);
//     Attachments: "calibration.json" (application/octet-stream; k4a_calibration_json);
//     Tags, each a SimpleTag, as k4arecorder writes them: K4A_DEPTH_TRACK (the track's UID) and
//       K4A_DEPTH_MODE targeted at the depth track; K4A_CUSTOM_TRACK_COLOR_ON_DEPTH at the color
//       track; K4A_WIRED_SYNC_MODE STANDALONE and K4A_START_OFFSET_NS (the first frame's device
//       time, ns) untargeted; K4A_CALIBRATION_FILE targeted at the attachment;
//     Clusters, one per capture: ClusterTimestamp = device time - start offset (µs), SimpleBlocks
//       (key frames) of depth then color at relative time 0;
//     Cues: one CuePoint per cluster, on the depth track.
// No IR track (a stream carries no infrared image) and no IMU track.
#include <cstdint>
#include <filesystem>
#include <memory>

#include "volcast/capture/k4a_calibration.hpp"
#include "volcast/core/frame.hpp"

namespace volcast {

class K4aMkvWriter {
 public:
  /// Creates `path` (overwriting it) for a camera with depth intrinsics `depth` of `mode` that
  /// captures a frame every `frame_us` microseconds; `with_color` adds the COLOR_ON_DEPTH track.
  /// Throws Error naming the file if it cannot be created.
  K4aMkvWriter(const std::filesystem::path& path, const Intrinsics& depth, K4aDepthMode mode,
               int64_t frame_us, bool with_color);
  ~K4aMkvWriter();
  K4aMkvWriter(const K4aMkvWriter&) = delete;
  K4aMkvWriter& operator=(const K4aMkvWriter&) = delete;

  /// Appends `frame` as one capture unless it has the device time of the capture written last (a
  /// camera slower than its site repeats a frame in several frame sets). Times that do not
  /// increase are moved 1 µs after the previous capture. Color (if any, registered to depth) is
  /// written as JPEG, quality 95. Throws Error naming the file on a write error or a frame of
  /// another size.
  void write(const CameraFrame& frame);

  /// Writes the cues, seek head and duration and closes the file. Throws Error naming the file.
  void close();

 private:
  struct State;
  std::unique_ptr<State> s_;
};

}  // namespace volcast
