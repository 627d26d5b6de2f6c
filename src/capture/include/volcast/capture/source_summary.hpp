#pragma once
// What `volcast info` says of a capture source -- an Azure Kinect recording (its streams, depth
// and color modes, frames, fps, duration, intrinsics) or an image-sequence folder (frames, those
// with a color file, fps, depth intrinsics) -- and of every one of its frames: each is read and
// decoded (check_frames), and those that cannot be are listed. As JSON (the keys the CLI has
// always written) or as lines for a person. Intrinsics in pixels, Brown-Conrady k1..k6, p1, p2.
#include <filesystem>
#include <functional>
#include <string>

#include "volcast/capture/k4a_recording.hpp"
#include "volcast/capture/source.hpp"

namespace volcast {

struct SourceSummary {
  std::filesystem::path path;
  bool sequence = false;  ///< an image-sequence folder; else an Azure Kinect recording
  // An image sequence:
  std::string description;
  int frames = 0, color_frames = 0;
  double fps = 0;
  Intrinsics depth;
  // An Azure Kinect recording:
  K4aRecordingInfo recording;
  FrameCheck check;  ///< every frame read once
};

/// Opens `path` (a folder: an image sequence; else an Azure Kinect recording) and reads every
/// frame, calling `progress(done, total)` after each if given. Throws Error if it cannot be
/// opened; frames that cannot be read are listed in check.bad, not thrown.
SourceSummary summarize_source(const std::filesystem::path& path,
                               const std::function<void(int, int)>& progress = {});

/// The summary as a JSON object (2-space indent).
std::string summary_json(const SourceSummary& s);

/// The summary as lines for a person, each ending in a newline; at most 50 bad frames listed
/// (summary_json lists all).
std::string summary_text(const SourceSummary& s);

}  // namespace volcast
