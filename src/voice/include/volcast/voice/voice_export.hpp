#pragma once
// A recording's voices (record/recording.hpp, format version 2) as WAV files, one per speaker:
// decoded with Opus (audio/opus_voice.hpp) on the recording's time line, a lost packet rebuilt
// from the next one's in-band FEC or concealed, the speaker's silences (DTX) silent.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace volcast::voice {

struct ExportedVoice {
  uint32_t participant = 0;
  std::string name;
  std::filesystem::path path;
  double seconds = 0;                   ///< the file's length
  uint64_t packets = 0, concealed = 0;  ///< packets decoded; frames rebuilt (FEC, PLC)
  /// Of the packets, those said before sample 0 (the first frame set): decoded, not written.
  uint64_t before_start = 0;
};

/// Writes `dir`/speaker-<id>-<name>.wav (48 kHz mono, 16-bit; characters other than letters,
/// digits, '-' and '_' in the name become '_') for every speaker of `recording`. Sample 0 is the
/// recording's first frame set's capture time (without frame sets, its first voice's). Creates
/// `dir`. Throws Error if the recording does not read or a file cannot be written; a packet that
/// does not decode is concealed and counted.
std::vector<ExportedVoice> export_voices(const std::filesystem::path& recording,
                                         const std::filesystem::path& dir);

}  // namespace volcast::voice
