#pragma once
// What a voice link sent and heard, for people (a table) and programs (JSON).
#include <nlohmann/json.hpp>
#include <string>

#include "volcast/voice/voice_link.hpp"

namespace volcast::voice {

/// {"started_us", "frames_captured", "packets_sent", "dtx_frames", "bytes_per_second", "hrtf",
///  "heard": [{"id", "name", "packets", "lost", "late", "duplicates", "malformed",
///  "concealed_percent", "jitter_delay_ms", "latency_ms_p50", "latency_ms_p99", "speaking",
///  "muted", "volume"}]} (times µs on the local wall clock, latencies ms).
nlohmann::json to_json(const VoiceStats& stats);
/// Prints a line per voice heard on standard output and, if `json_path` is not empty, writes
/// to_json there. Throws Error if the file cannot be written.
void report_voice(const VoiceStats& stats, const std::string& json_path);

}  // namespace volcast::voice
