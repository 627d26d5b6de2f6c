#pragma once
// What `volcast info FILE.vcr` says of a recording: its tier and origin, cameras (intrinsics,
// pixels; world_from_camera's translation, metres), frame sets and key frame sets, how long it
// plays (playback_timeline: a capture time that jumps or goes back is a clamped gap, named in a
// warning), the voices (speaker_summaries) and the drawing (annotations drawn, erased), whether
// its recorder closed it, and whether every record's CRC holds. As JSON (the keys the CLI has
// always written) or as lines for a person.
#include <cstdint>
#include <functional>
#include <string>

#include "volcast/record/recording.hpp"

namespace volcast {

struct RecordingSummary {
  std::string path;
  const RecordingInfo* info = nullptr;  ///< the reader's; must outlive the summary
  size_t key_frame_sets = 0;
  PlaybackTimeline timeline;
  double duration_s = 0;    ///< as replay plays it
  std::string gap_warning;  ///< the first clamped gap (and how many more); empty without one
  std::vector<SpeakerSummary> speakers;
  size_t annotations_drawn = 0, annotations_erased = 0;
  std::string error;  ///< the first record whose CRC or structure fails; empty: all verified
};

/// Reads `reader`'s index and verifies every record (RecordingReader::verify; `progress(done,
/// total)` called as it goes, if given). A record that fails is named in `error`, not thrown.
RecordingSummary summarize_recording(RecordingReader& reader, const std::string& path,
                                     const std::function<void(size_t, size_t)>& progress = {});

/// The summary as a JSON object (2-space indent): kind, path, depth_codec, color_codec,
/// color_quality, origin, cameras, format_version, speakers, annotations_drawn,
/// annotations_erased, frame_sets, key_frame_sets, duration_s, clamped_gaps, warning, fps,
/// file_bytes, closed, incomplete_tail_at, verified, error.
std::string summary_json(const RecordingSummary& s);

/// The summary as lines for a person, each ending in a newline.
std::string summary_text(const RecordingSummary& s);

}  // namespace volcast
