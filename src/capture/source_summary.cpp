// What `volcast info` says of a capture source (source_summary.hpp).
#include "volcast/capture/source_summary.hpp"

#include <fmt/format.h>

#include <nlohmann/json.hpp>

namespace volcast {
namespace {

std::string intrinsics_line(const Intrinsics& k) {
  return fmt::format(
      "{}x{}  fx {:.4f} fy {:.4f} cx {:.4f} cy {:.4f}  k1..k6 {:.6g} {:.6g} {:.6g} {:.6g} {:.6g} "
      "{:.6g}  p1 {:.6g} p2 {:.6g}",
      k.width, k.height, k.fx, k.fy, k.cx, k.cy, k.k1, k.k2, k.k3, k.k4, k.k5, k.k6, k.p1, k.p2);
}

nlohmann::json intrinsics_json(const Intrinsics& k) {
  return {{"width", k.width},
          {"height", k.height},
          {"fx", k.fx},
          {"fy", k.fy},
          {"cx", k.cx},
          {"cy", k.cy},
          {"k1", k.k1},
          {"k2", k.k2},
          {"k3", k.k3},
          {"k4", k.k4},
          {"k5", k.k5},
          {"k6", k.k6},
          {"p1", k.p1},
          {"p2", k.p2},
          {"codx", k.codx},
          {"cody", k.cody},
          {"metric_radius", k.metric_radius}};
}

void add_check_json(const FrameCheck& c, nlohmann::json& j) {
  j["checked_frames"] = c.frames;
  j["bad_frame_count"] = c.bad.size();
  j["bad_frames"] = nlohmann::json::array();
  for (const auto& b : c.bad) j["bad_frames"].push_back({{"index", b.index}, {"error", b.error}});
  j["frames_without_color"] = c.frames_without_color;
}

std::string check_text(const FrameCheck& c) {
  constexpr size_t kListed = 50;  // the JSON lists every one
  std::string out = fmt::format(
      "  checked {} frames: {} cannot be read{}, {} without color\n", c.frames, c.bad.size(),
      c.bad.empty() ? "" : " (skipped when streaming)", c.frames_without_color);
  for (size_t i = 0; i < c.bad.size() && i < kListed; ++i)
    out += fmt::format("    BAD frame {}: {}\n", c.bad[i].index, c.bad[i].error);
  if (c.bad.size() > kListed)
    out += fmt::format("    ... and {} more (--json lists all)\n", c.bad.size() - kListed);
  return out;
}

}  // namespace

SourceSummary summarize_source(const std::filesystem::path& path,
                               const std::function<void(int, int)>& progress) {
  SourceSummary s;
  s.path = path;
  s.sequence = std::filesystem::is_directory(path);
  if (!s.sequence) s.recording = probe_k4a_recording(path);
  auto src = open_source(path, {});
  if (s.sequence) {
    s.description = src->description();
    s.frames = src->frame_count();
    s.color_frames = src->color_frame_count();
    s.fps = src->fps();
    s.depth = src->calibration().depth;
  }
  s.check = check_frames(*src, progress);
  return s;
}

std::string summary_json(const SourceSummary& s) {
  nlohmann::json j;
  if (s.sequence) {
    j = {{"kind", "image sequence"},
         {"path", s.path.string()},
         {"frames", s.frames},
         {"color_frames", s.color_frames},
         {"fps", s.fps},
         {"depth_intrinsics", intrinsics_json(s.depth)}};
  } else {
    const K4aRecordingInfo& info = s.recording;
    j = {{"kind", "Azure Kinect recording"},
         {"path", s.path.string()},
         {"depth_mode", info.depth_mode},
         {"color_mode", info.color_mode},
         {"depth_frames", info.depth_frames},
         {"color_frames", info.color_frames},
         {"duration_s", info.duration_s},
         {"fps", info.fps},
         {"depth_intrinsics", intrinsics_json(info.depth_intrinsics)}};
    if (info.color_intrinsics.width) j["color_intrinsics"] = intrinsics_json(info.color_intrinsics);
    j["streams"] = nlohmann::json::array();
    for (const auto& st : info.streams)
      j["streams"].push_back({{"index", st.index},
                              {"title", st.title},
                              {"codec", st.codec},
                              {"width", st.width},
                              {"height", st.height}});
  }
  add_check_json(s.check, j);
  return j.dump(2);
}

std::string summary_text(const SourceSummary& s) {
  std::string out;
  if (s.sequence) {
    out = fmt::format(
        "{}\n  frames: {} at {:.1f} fps, {} with a color file\n  depth intrinsics: {}\n",
        s.description, s.frames, s.fps, s.color_frames, intrinsics_line(s.depth));
    return out + check_text(s.check);
  }
  const K4aRecordingInfo& info = s.recording;
  out = fmt::format("Azure Kinect recording {}\n  streams:\n", s.path.string());
  for (const auto& st : info.streams)
    out += fmt::format("    #{} {:<16} {:<10} {}\n", st.index, st.title, st.codec,
                       st.width ? fmt::format("{}x{}", st.width, st.height) : "");
  out += fmt::format("  depth mode {}, color mode {}\n", info.depth_mode,
                     info.color_mode.empty() ? "(none)" : info.color_mode);
  out += fmt::format("  frames: {} depth, {} color, {:.0f} fps, duration {:.3f} s\n",
                     info.depth_frames, info.color_frames, info.fps, info.duration_s);
  out += fmt::format("  depth intrinsics: {}\n", intrinsics_line(info.depth_intrinsics));
  if (info.color_intrinsics.width)
    out += fmt::format("  color intrinsics: {}\n", intrinsics_line(info.color_intrinsics));
  return out + check_text(s.check);
}

}  // namespace volcast
