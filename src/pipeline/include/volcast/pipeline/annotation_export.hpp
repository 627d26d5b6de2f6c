#pragma once
// A recording's annotations (recording.hpp Drawing records, format version 3) for other tools:
// each stroke, arrow and label as drawn in the recorded session, with when it was drawn and
// erased, as JSON (`volcast export --annotations`).
#include <cstdint>
#include <filesystem>
#include <optional>
#include <vector>

#include "volcast/record/recording.hpp"
#include "volcast/session/annotations.hpp"

namespace volcast {

/// One annotation of a recorded session.
struct RecordedAnnotation {
  /// As the session sent it (0x51): its id and author are the recorded session's, its time when
  /// the server took it (server clock, us), its points in the room frame, metres.
  session::Annotation annotation;
  int64_t received_us = 0;           ///< when the recorder received it (server clock, us)
  std::optional<int64_t> erased_us;  ///< when the recorder received its 0x52 (server clock)
  uint32_t erased_by = 0;            ///< who erased it (0: the server), if it was
};

/// Every annotation in `reader`'s recording, in the order the recorder received them (those the
/// session held when it joined first); one recorded twice (the same id) is listed once, as last
/// recorded, with its first receive time. An erasure of an id the recording never drew is
/// ignored. Throws Error as RecordingReader::read_drawing does (a corrupt Drawing record).
std::vector<RecordedAnnotation> recorded_annotations(RecordingReader& reader);

/// Writes the annotations of the recording at `recording` to `json` (mode 0600, replaced if it
/// exists), UTF-8:
///   {"kind": "Volcast annotations", "recording": path, "frame": "room", "units": "metres",
///    "time_zero_us": the first frame set's capture time (server clock; the first drawing's
///      receive time in a recording without frame sets, 0 with neither),
///    "annotations": [{"id", "author": {"id", "name"}, "kind": "stroke" | "arrow" | "label",
///      "anchor": "room" | "monitor", "generation", "slice", "tag", "points": [[x, y, z], ...]
///      (room frame, metres; each the shortest decimal that reads back as the float the session
///      carried), "text", "drawn_us" (server clock), "drawn_s" (drawn_us - time_zero_us, in
///      seconds; negative for what was drawn before the recording began), "received_us",
///      "erased_us" and "erased_s" (null while it stands), "erased_by"
///      ({"id", "name"}, null while it stands)}, ...]}
/// in recorded_annotations' order. A name is the participant's display name from the
/// recording's Speaker record, null where it has none (id 0: the server). Returns how many
/// annotations it wrote. Throws Error if the recording cannot be read or the file written.
size_t export_annotations(const std::filesystem::path& recording,
                          const std::filesystem::path& json);

}  // namespace volcast
