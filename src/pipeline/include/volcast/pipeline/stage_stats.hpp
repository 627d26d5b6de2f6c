#pragma once
// Per-stage latency of the stream, from the sender's and receiver's timestamps of each frame set
// (one clock: see StageTimes). Stages, each named by where it ends:
//   filter  capture -> filter chains done         encode   -> every camera of the tier encoded
//   send    -> the server began sending (waiting for the path's window)
//   receive -> the whole message read by the viewer  decode -> every camera decoded
//   ready   -> the decoded images handed to the renderer, which unprojects them into points on the
//              GPU (CameraRenderer::draw_cameras): nothing is left for the CPU after this stage
//   presented -> the first picture showing them handed to the display: the window's buffer swap
//              returned, the headset's frame submitted (xrEndFrame), the headless target's draw
//              finished (FrameFeed::presented); over the frame sets shown, not those a newer
//              one replaced before the next draw
//   total   capture -> ready
//   photon  capture -> presented: the camera-to-photon latency, less the display's scan-out, to
//           set against the seed's motion-to-photon figure (Fischer et al. 2024: 120-150 ms)
#include <array>
#include <cstdint>
#include <string_view>
#include <vector>

namespace volcast {

struct StageTimes;  // volcast/net/stream/client.hpp

inline constexpr std::array<std::string_view, 9> kStageNames = {
    "filter", "encode", "send", "receive", "decode", "ready", "presented", "total", "photon"};

struct StageLatency {
  std::string_view stage;
  double p50_ms = 0, p99_ms = 0, mean_ms = 0;
};

/// Collects per-frame-set stage durations; summary() gives p50/p99 per stage in kStageNames order.
class StageRecorder {
 public:
  /// `ready_us`: when the frame set was handed to the renderer, same clock as `t`.
  void add(const StageTimes& t, int64_t ready_us);
  /// A frame set first presented: ready -> presented and capture -> presented, milliseconds.
  void add_presented(double presented_ms, double photon_ms);
  std::vector<StageLatency> summary() const;

 private:
  std::array<std::vector<double>, kStageNames.size()> samples_;  // milliseconds
};

/// The value at quantile `p` (0..1) of `v` (nearest rank); 0 for an empty list.
double percentile(std::vector<double> v, double p);

}  // namespace volcast
