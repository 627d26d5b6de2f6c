// volcast info: describes an Azure Kinect recording, an image sequence or (record_commands.cpp) a
// Volcast recording, checking every frame.
#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "cli.hpp"
#include "commands.hpp"
#include "volcast/capture/k4a_recording.hpp"
#include "volcast/capture/source.hpp"

namespace volcast {
namespace fs = std::filesystem;
namespace {

// The four corners of the intrinsics line `volcast info` prints.
std::string intrinsics_line(const Intrinsics& k) {
  return fmt::format(
      "{}x{}  fx {:.4f} fy {:.4f} cx {:.4f} cy {:.4f}  k1..k6 {:.6g} {:.6g} {:.6g} {:.6g} {:.6g} "
      "{:.6g}"
      "  p1 {:.6g} p2 {:.6g}",
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

// Reads every frame of a freshly opened source (one pass), with a progress line on stderr when a
// person watches (a terminal), as the server benchmark does.
FrameCheck check_every_frame(FrameSource& src) {
  const bool tty = isatty(STDERR_FILENO);
  int shown = -1;
  FrameCheck c = check_frames(src, [&](int done, int total) {
    const int percent = done * 100 / std::max(total, 1);
    if (!tty || percent == shown) return;
    shown = percent;
    std::fprintf(stderr, "\rchecking every frame: %d/%d (%d %%)", done, total, percent);
  });
  if (tty) std::fprintf(stderr, "\r\033[K");  // clear the progress line
  return c;
}

void add_check_json(const FrameCheck& c, nlohmann::json& j) {
  j["checked_frames"] = c.frames;
  j["bad_frame_count"] = c.bad.size();
  j["bad_frames"] = nlohmann::json::array();
  for (const auto& b : c.bad) j["bad_frames"].push_back({{"index", b.index}, {"error", b.error}});
  j["frames_without_color"] = c.frames_without_color;
}

void print_check(const FrameCheck& c) {
  constexpr size_t kListed = 50;  // --json lists every one
  std::printf("  checked %d frames: %zu cannot be read%s, %d without color\n", c.frames,
              c.bad.size(), c.bad.empty() ? "" : " (skipped when streaming)",
              c.frames_without_color);
  for (size_t i = 0; i < c.bad.size() && i < kListed; ++i)
    std::printf("    BAD frame %d: %s\n", c.bad[i].index, c.bad[i].error.c_str());
  if (c.bad.size() > kListed)
    std::printf("    ... and %zu more (--json lists all)\n", c.bad.size() - kListed);
}

}  // namespace

// Exit code 0 whenever the source opens, bad frames or not: they are listed (and counted in
// bad_frame_count) for the reader to act on; 1 if the source cannot be opened at all.
int run_info(const InfoArgs& a) {
  const fs::path path = a.file;
  if (path.extension() == ".vcr") return run_recording_info(a);
  nlohmann::json j;
  if (fs::is_directory(path)) {
    auto src = open_source(path, {});
    const auto& k = src->calibration().depth;
    const FrameCheck check = check_every_frame(*src);
    j = {{"kind", "image sequence"},
         {"path", path.string()},
         {"frames", src->frame_count()},
         {"color_frames", src->color_frame_count()},
         {"fps", src->fps()},
         {"depth_intrinsics", intrinsics_json(k)}};
    add_check_json(check, j);
    if (a.json) {
      std::printf("%s\n", j.dump(2).c_str());
    } else {
      std::printf("%s\n  frames: %d at %.1f fps, %d with a color file\n  depth intrinsics: %s\n",
                  src->description().c_str(), src->frame_count(), src->fps(),
                  src->color_frame_count(), intrinsics_line(k).c_str());
      print_check(check);
    }
    return 0;
  }
  const K4aRecordingInfo info = probe_k4a_recording(path);
  const FrameCheck check = check_every_frame(*open_source(path, {}));
  if (a.json) {
    j = {{"kind", "Azure Kinect recording"},
         {"path", path.string()},
         {"depth_mode", info.depth_mode},
         {"color_mode", info.color_mode},
         {"depth_frames", info.depth_frames},
         {"color_frames", info.color_frames},
         {"duration_s", info.duration_s},
         {"fps", info.fps},
         {"depth_intrinsics", intrinsics_json(info.depth_intrinsics)}};
    if (info.color_intrinsics.width) j["color_intrinsics"] = intrinsics_json(info.color_intrinsics);
    j["streams"] = nlohmann::json::array();
    for (const auto& s : info.streams)
      j["streams"].push_back({{"index", s.index},
                              {"title", s.title},
                              {"codec", s.codec},
                              {"width", s.width},
                              {"height", s.height}});
    add_check_json(check, j);
    std::printf("%s\n", j.dump(2).c_str());
    return 0;
  }
  std::printf("Azure Kinect recording %s\n", path.c_str());
  std::printf("  streams:\n");
  for (const auto& s : info.streams)
    std::printf("    #%d %-16s %-10s %s\n", s.index, s.title.c_str(), s.codec.c_str(),
                s.width ? fmt::format("{}x{}", s.width, s.height).c_str() : "");
  std::printf("  depth mode %s, color mode %s\n", info.depth_mode.c_str(),
              info.color_mode.empty() ? "(none)" : info.color_mode.c_str());
  std::printf("  frames: %d depth, %d color, %.0f fps, duration %.3f s\n", info.depth_frames,
              info.color_frames, info.fps, info.duration_s);
  std::printf("  depth intrinsics: %s\n", intrinsics_line(info.depth_intrinsics).c_str());
  if (info.color_intrinsics.width)
    std::printf("  color intrinsics: %s\n", intrinsics_line(info.color_intrinsics).c_str());
  print_check(check);
  return 0;
}

void register_info(CLI::App& app, Commands& commands) {
  auto [i, info] = add_command<InfoArgs>(
      app, commands, run_info, "info",
      "Describe a recording: streams, frames, derived intrinsics; reads every frame and lists "
      "those that cannot be read (exit code 0 whenever the source opens)");
  i->add_option("file", info.file,
                "Azure Kinect .mkv, image-sequence folder, or Volcast recording .vcr")
      ->required();
  i->add_flag("--json", info.json, "Print JSON");
}

}  // namespace volcast
