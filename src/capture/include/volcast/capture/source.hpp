#pragma once
// Frame sources: one camera each (an Azure Kinect recording, an image-sequence folder, a camera
// folder's depth PNGs). Several sources form one site; the server reads one frame from each per
// frame set.
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "volcast/core/calibration.hpp"
#include "volcast/core/frame.hpp"

namespace volcast {

/// One camera's stream of RGB-D frames. Implementations: Azure Kinect recordings (k4arecorder
/// Matroska), image-sequence folders and camera folders' depth PNGs (camera_folder.hpp; their
/// color is resampled, not registered). Not thread-safe; one reader at a time.
class FrameSource {
 public:
  virtual ~FrameSource() = default;
  /// Depth intrinsics (color comes on the depth grid: registered to depth, except a camera
  /// folder's, which is resampled) and world_from_camera.
  virtual const CameraCalibration& calibration() const = 0;
  /// Frame rate of the recording, frames per second (as recorded; 30 where a format has none).
  virtual double fps() const = 0;
  /// Number of frames in one pass of the recording.
  virtual int frame_count() const = 0;
  /// Frames of one pass that carry color, as far as the source knows without decoding them: 0 for
  /// a depth-only source; less than frame_count() when some frames have none. A frame without
  /// color has an empty ColorImage (0 x 0) -- sent as a zero-length color stream.
  virtual int color_frame_count() const = 0;
  /// Reads the next frame (depth and registered color of calibration().depth's size, or empty
  /// color) into `out`, reusing its images' buffers where it can: a capture loop that recycles
  /// its frames allocates nothing per frame for a still or recorded camera. After the last frame
  /// it starts again at the first (playback loops). Throws Error naming the file (and frame) on
  /// corrupt data, leaving `out` valid but unspecified; the frame is then skipped: the next call
  /// reads the frame after it.
  virtual void next(CameraFrame& out) = 0;
  /// The same, into a new frame.
  CameraFrame next() {
    CameraFrame f;
    next(f);
    return f;
  }
  /// Human-readable description (kind and path) for logs.
  virtual std::string description() const = 0;
};

/// A color camera's calibration relative to its depth camera.
struct ColorCalibration {
  Intrinsics intrinsics;            ///< of the color image, pixels (its width and height set)
  RigidTransform color_from_depth;  ///< metres
};

/// Options shared by every source kind.
struct SourceOptions {
  /// Intrinsics (pinhole or the full lens model) for sources that carry none: an image sequence
  /// without intrinsics.json, a depth PNG. Width/height 0 = take the images'; else they must match.
  std::optional<Intrinsics> intrinsics;
  /// Overrides the recording's frame rate (frames per second).
  std::optional<double> fps;
  /// Places the camera in the site's world frame (default: identity).
  std::optional<RigidTransform> world_from_camera;
  /// For a camera folder's still PNGs, whose color is not registered to depth: register it with
  /// this calibration (ColorToDepthRegistration, registration.hpp) when the color image is its
  /// size -- e.g. another Azure Kinect's factory calibration as a nominal one
  /// (nominal_kinect_color in real_sites.hpp). Without it the color is resampled, not registered.
  std::optional<ColorCalibration> nominal_color;
};

/// Opens PATH as a source: a directory is an image sequence, a `.mkv` file an Azure Kinect
/// recording, a `.png` file one camera of a camera folder (depth.<serial>-<n>.png, color NOT
/// registered) or else a single still depth frame (volcast/capture/camera_folder.hpp; both need
/// options.intrinsics). A directory holding depth.<serial>-*.png files but no depth/ folder is a
/// camera folder, refused with an Error saying how many cameras it holds and how to open them.
/// Throws Error naming the path and what is wrong with it.
std::unique_ptr<FrameSource> open_source(const std::filesystem::path& path,
                                         const SourceOptions& options = {});

/// One frame that could not be read.
struct BadFrame {
  int index = 0;      ///< position in the pass, 0-based
  std::string error;  ///< the source's Error: names the file (or recording and time) and why
};

/// What check_frames found in one pass of a source.
struct FrameCheck {
  int frames = 0;                ///< frames read (good and bad): frame_count()
  int frames_without_color = 0;  ///< good frames with an empty color image
  std::vector<BadFrame> bad;     ///< in order
};

/// Reads frame_count() frames from `source` (one pass, from where it stands: a freshly opened
/// source starts at its first frame), decoding each, and lists those that throw. `progress`, if
/// given, is called after each frame with (frames done, frames in all). Other exceptions than
/// Error propagate.
FrameCheck check_frames(FrameSource& source,
                        const std::function<void(int done, int total)>& progress = {});

}  // namespace volcast
