#pragma once
// Frame sources: one camera each (an Azure Kinect recording, an image-sequence folder). Several
// sources form one site; the server reads one frame from each per frame set.
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "volcast/core/calibration.hpp"
#include "volcast/core/frame.hpp"

namespace volcast {

/// One camera's stream of registered RGB-D frames. Implementations: Azure Kinect recordings
/// (k4arecorder Matroska) and image-sequence folders. Not thread-safe; one reader at a time.
class FrameSource {
 public:
  virtual ~FrameSource() = default;
  /// Depth intrinsics (color is registered to depth) and world_from_camera.
  virtual const CameraCalibration& calibration() const = 0;
  /// Frame rate of the recording, frames per second (as recorded; 30 where a format has none).
  virtual double fps() const = 0;
  /// Number of frames in one pass of the recording.
  virtual int frame_count() const = 0;
  /// Reads the next frame (depth and registered color of calibration().depth's size); after the
  /// last frame it starts again at the first (playback loops). Throws Error on corrupt data.
  virtual CameraFrame next() = 0;
  /// Human-readable description (kind and path) for logs.
  virtual std::string description() const = 0;
};

/// Options shared by every source kind.
struct SourceOptions {
  /// Pinhole intrinsics to use when an image sequence has no intrinsics.json (fx, fy, cx, cy).
  std::optional<Intrinsics> intrinsics;
  /// Overrides the recording's frame rate (frames per second).
  std::optional<double> fps;
  /// Places the camera in the site's world frame (default: identity).
  std::optional<RigidTransform> world_from_camera;
};

/// Opens PATH as a source: a directory is an image sequence, a `.mkv` file an Azure Kinect
/// recording. Throws Error naming the path and what is wrong with it.
std::unique_ptr<FrameSource> open_source(const std::filesystem::path& path,
                                         const SourceOptions& options = {});

}  // namespace volcast
