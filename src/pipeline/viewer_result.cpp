// How a viewer's session ended, and its figures as JSON or a table.
#include "volcast/pipeline/viewer_result.hpp"

#include <fmt/format.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "volcast/core/error.hpp"
#include "volcast/core/text.hpp"

namespace volcast {

const char* to_string(ViewerEnd end) {
  switch (end) {
    case ViewerEnd::kFramesReached:
      return "frames_reached";
    case ViewerEnd::kSecondsReached:
      return "seconds_reached";
    case ViewerEnd::kInterrupted:
      return "interrupted";
    case ViewerEnd::kClosed:
      return "closed";
    case ViewerEnd::kServerClosed:
      return "server_closed";
    case ViewerEnd::kTimedOut:
      return "timed_out";
    case ViewerEnd::kRejected:
      return "rejected";
    case ViewerEnd::kProtocolError:
      return "protocol_error";
    case ViewerEnd::kConnectionLost:
      return "connection_lost";
    case ViewerEnd::kError:
      return "error";
  }
  return "error";
}

void write_stats_json(const std::filesystem::path& path, const ViewerResult& r) {
  nlohmann::json j;
  j["ended"] = to_string(r.ended);
  j["error"] = r.error.empty() ? nlohmann::json(nullptr) : nlohmann::json(r.error);
  j["frame_sets_received"] = r.frame_sets_received;
  j["depth_codec"] = r.tier.depth_codec;
  j["color_codec"] = r.tier.color_codec;
  j["tier"] = to_string(r.tier);
  j["adaptive"] = r.adaptive;
  j["tier_changes"] = nlohmann::json::array();
  for (const TierEvent& e : r.tier_events)
    j["tier_changes"].push_back({{"time_us", e.time_us},
                                 {"tier", to_string(e.tier)},
                                 {"lossless_depth", e.lossless_depth},
                                 {"notice", e.notice},
                                 {"path_mbit_s", e.path_mbit_s},
                                 {"reason", e.reason}});
  j["outages"] = nlohmann::json::array();
  for (const ViewerResult::Outage& o : r.outages)
    j["outages"].push_back({{"lost_us", o.lost_us}, {"back_us", o.back_us}, {"why", o.why}});
  j["frames_stale"] = r.frames_stale;
  j["frames_rendered"] = r.frames_rendered;
  j["renderer"] = r.renderer;
  j["blend_off"] = r.blend_off;
  j["frames_undecodable"] = r.frames_undecodable;
  j["stages"] = nlohmann::json::array();
  for (const StageLatency& l : r.stages)
    j["stages"].push_back(
        {{"stage", l.stage}, {"p50_ms", l.p50_ms}, {"p99_ms", l.p99_ms}, {"mean_ms", l.mean_ms}});
  j["cameras"] = nlohmann::json::array();
  for (size_t i = 0; i < r.cameras.size(); ++i) {
    const CameraStats& s = r.cameras[i];
    j["cameras"].push_back({{"camera", i},
                            {"description", s.description},
                            {"width", s.width},
                            {"height", s.height},
                            {"frames_received", s.frames_received},
                            {"frames_dropped", s.frames_dropped},
                            {"mean_depth_bytes", s.mean_depth_bytes},
                            {"mean_color_bytes", s.mean_color_bytes},
                            {"depth_compression_ratio", s.depth_compression_ratio},
                            {"received_fps", s.received_fps},
                            {"mbit_per_s", s.mbit_per_s},
                            {"latency_ms_p50", s.latency_ms_p50},
                            {"latency_ms_p99", s.latency_ms_p99}});
  }
  if (r.session) {
    const ParticipantStats& p = *r.session;
    j["session"] = r.session_name;
    j["session_round_trip_ms_p50"] = p.round_trip_ms_p50;
    j["session_round_trip_ms_p99"] = p.round_trip_ms_p99;
    j["round_trip_samples"] = p.round_trip_samples;
    j["poses_sent"] = p.poses_sent;
    j["avatar_frames_sent"] = p.avatar_frames_sent;
    j["participants"] = nlohmann::json::array();
    j["others"] = nlohmann::json::array();
    for (const RemoteStats& o : p.others) {
      j["participants"].push_back(o.name);
      j["others"].push_back({{"id", o.id},
                             {"name", o.name},
                             {"poses_received", o.poses_received},
                             {"pose_rate_hz", o.pose_rate_hz},
                             {"pose_age_ms_p50", o.pose_age_ms_p50},
                             {"pose_age_ms_p99", o.pose_age_ms_p99},
                             {"avatar_frames_received", o.avatar_frames_received},
                             {"avatar_fps", o.avatar_fps},
                             {"avatar_latency_ms_p50", o.avatar_latency_ms_p50},
                             {"avatar_latency_ms_p99", o.avatar_latency_ms_p99}});
    }
  }
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path());
  std::ofstream out(path);
  out << j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) << "\n";
  if (!out) throw Error("cannot write '" + path.string() + "'");
}

std::string format_stats_table(const ViewerResult& r) {
  size_t switches = 0;  // the server's first word only says where the viewer starts
  for (size_t i = 1; i < r.tier_events.size(); ++i) switches += !r.tier_events[i].notice;
  std::string s = fmt::format("tier {}{}, {} frames rendered{}\n", to_string(r.tier),
                              r.adaptive ? fmt::format(" (adaptive, {} switches)", switches) : "",
                              r.frames_rendered, r.renderer.empty() ? "" : " (" + r.renderer + ")");
  for (const TierEvent& e : r.tier_events)
    s += fmt::format("  tier {}{}{}: {}\n", to_string(e.tier),
                     e.lossless_depth ? "" : " (lossy depth)", e.notice ? " kept" : "", e.reason);
  for (const ViewerResult::Outage& o : r.outages)
    s += o.back_us > 0 ? fmt::format("  reconnected after {:.1f} s: {}\n",
                                     static_cast<double>(o.back_us - o.lost_us) / 1e6, o.why)
                       : fmt::format("  cut, not reconnected: {}\n", o.why);
  if (!r.blend_off.empty()) s += "  " + r.blend_off + "\n";
  if (r.frames_stale > 0)
    s += fmt::format("  {} stale frame sets not drawn (queued while the path stalled)\n",
                     r.frames_stale);
  s += fmt::format("{:<4} {:>9} {:>8} {:>7} {:>12} {:>12} {:>7} {:>7} {:>8} {:>8}  {}\n", "cam",
                   "size", "frames", "dropped", "depth B/fr", "color B/fr", "ratio", "fps",
                   "Mbit/s", "lat p50", "lat p99 / source");
  for (size_t i = 0; i < r.cameras.size(); ++i) {
    const CameraStats& c = r.cameras[i];
    s += fmt::format(
        "{:<4} {:>9} {:>8} {:>7} {:>12.0f} {:>12.0f} {:>6.2f}x {:>7.1f} {:>8.2f} {:>6.1f}ms  "
        "{:.1f}ms  {}\n",
        i, fmt::format("{}x{}", c.width, c.height), c.frames_received, c.frames_dropped,
        c.mean_depth_bytes, c.mean_color_bytes, c.depth_compression_ratio, c.received_fps,
        c.mbit_per_s, c.latency_ms_p50, c.latency_ms_p99, c.description);
  }
  if (!r.stages.empty()) {
    s += "latency by stage (ms)  ";
    for (const StageLatency& l : r.stages) s += fmt::format("{:>10}", l.stage);
    s += "\n                  p50  ";
    for (const StageLatency& l : r.stages) s += fmt::format("{:>10.2f}", l.p50_ms);
    s += "\n                  p99  ";
    for (const StageLatency& l : r.stages) s += fmt::format("{:>10.2f}", l.p99_ms);
    s += "\n";
  }
  if (r.session) {
    const ParticipantStats& p = *r.session;
    s += fmt::format(
        "session '{}': round trip p50 {:.2f} ms, p99 {:.2f} ms ({} samples); {} poses "
        "sent, {} avatar frames sent\n",
        printable(r.session_name), p.round_trip_ms_p50, p.round_trip_ms_p99, p.round_trip_samples,
        p.poses_sent, p.avatar_frames_sent);
    for (const RemoteStats& o : p.others)
      s += fmt::format(
          "  {:<20} poses {:>6} at {:>6.1f} Hz, age p50 {:>6.2f} ms p99 {:>6.2f} ms; "
          "avatar frames {:>5} at {:>5.1f} fps, latency p50 {:>6.1f} ms\n",
          printable(o.name, 20), o.poses_received, o.pose_rate_hz, o.pose_age_ms_p50,
          o.pose_age_ms_p99, o.avatar_frames_received, o.avatar_fps, o.avatar_latency_ms_p50);
  }
  s += fmt::format("ended: {} after {} frame sets{}\n", to_string(r.ended), r.frame_sets_received,
                   r.error.empty() ? "" : ": " + r.error);
  return s;
}

}  // namespace volcast
