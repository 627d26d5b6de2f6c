#pragma once
// What a viewer's session (run_viewer, receiver.hpp) returns: how it ended and the figures of the
// whole run, as a table or JSON.
#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "volcast/codec/tier.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/frame.hpp"
#include "volcast/pipeline/frame_feed.hpp"
#include "volcast/pipeline/stage_stats.hpp"
#include "volcast/session/participant.hpp"

namespace volcast {

/// Why a viewer's session ended. The first four are normal ends; from kTimedOut on, errors.
enum class ViewerEnd {
  kFramesReached,   ///< ViewerOptions::frames frame sets received
  kSecondsReached,  ///< ViewerOptions::seconds passed
  kInterrupted,     ///< the external stop flag was set (Ctrl-C; the demo once its session settled)
  kClosed,          ///< the presenter closed the session (the user closed the window)
  kServerClosed,    ///< the server closed the connection between messages
  kTimedOut,        ///< the server was silent past the handshake or receive timeout
  kRejected,        ///< the server refused the viewer (Reject)
  kProtocolError,   ///< a malformed or oversized message, a frame of the wrong size
  kConnectionLost,  ///< the connection broke
  kError,           ///< anything else: cannot connect, unknown codec, the renderer failed, ...
};
/// "frames_reached", "seconds_reached", "interrupted", "closed", "server_closed", "timed_out",
/// "rejected", "protocol_error", "connection_lost", "error".
const char* to_string(ViewerEnd end);

struct ViewerResult {
  ViewerEnd ended = ViewerEnd::kServerClosed;
  std::string error;  ///< what went wrong, for the error ends; empty otherwise
  uint64_t frame_sets_received = 0;
  Tier tier;                           ///< the tier at the end
  bool adaptive = false;               ///< the server moved it along its ladder
  std::vector<TierEvent> tier_events;  ///< every change and notice (the first 256)
  std::vector<CameraStats> cameras;
  uint64_t frames_rendered = 0;
  uint64_t frames_undecodable = 0;  ///< skipped: a delta without its reference (key requested)
  /// Each cut the viewer reconnected after (ViewerOptions::reconnect): when it was noticed and
  /// when frames came again (wall clock, us; back_us 0: never), and what broke.
  struct Outage {
    int64_t lost_us = 0, back_us = 0;
    std::string why;
  };
  std::vector<Outage> outages;
  uint64_t frames_stale = 0;         ///< frame sets decoded but not drawn: older than stale_ms
  std::vector<StageLatency> stages;  ///< per-stage latency, kStageNames order
  std::string renderer;              ///< GL renderer string, empty when not rendering
  /// Why the window's or headset's frame budget turned blending off (FrameBudget::reason(),
  /// volcast/render/frame_budget.hpp); empty where it did not.
  std::string blend_off;
  /// The last frame set's decoded images, per camera (null for a camera that sent none).
  std::vector<std::shared_ptr<const CameraFrame>> last_frames;
  /// A participant's session figures (round trip, the others' pose rates and ages, avatar
  /// latency) and the session it was in; absent for a plain viewer.
  std::optional<ParticipantStats> session;
  std::string session_name;
};

/// Thrown by run_viewer when the session ended on an error (ViewerEnd kTimedOut and after):
/// what() is the reason, result() the figures up to then.
class ViewerError : public Error {
 public:
  ViewerError(const std::string& message, std::shared_ptr<const ViewerResult> result)
      : Error(message), result_(std::move(result)) {}
  const ViewerResult& result() const { return *result_; }

 private:
  std::shared_ptr<const ViewerResult> result_;
};

/// Writes the figures as JSON ({"ended", "error" (null when none), "frame_sets_received",
/// "depth_codec", "color_codec", "tier", "adaptive", "tier_changes": [{"time_us", "tier",
/// "lossless_depth", "notice", "path_mbit_s", "reason"}], "outages": [{"lost_us", "back_us",
/// "why"}], "frames_stale", "frames_rendered", "cameras": [...],
/// "stages": [{"stage", "p50_ms", "p99_ms", "mean_ms"}, ...]}; for a participant also "session"
/// (name), "participants" (the others' names), "session_round_trip_ms_p50" / "_p99",
/// "round_trip_samples", "poses_sent", "avatar_frames_sent" and per other participant {"id",
/// "name", "poses_received", "pose_rate_hz", "pose_age_ms_p50", "pose_age_ms_p99",
/// "avatar_frames_received", "avatar_fps", "avatar_latency_ms_p50", "avatar_latency_ms_p99"} in
/// "others"). Throws Error if it cannot write the file.
void write_stats_json(const std::filesystem::path& path, const ViewerResult& result);
/// A short human-readable table of the figures, with the per-stage latencies and how the session
/// ended.
std::string format_stats_table(const ViewerResult& result);

}  // namespace volcast
