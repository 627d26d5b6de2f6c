// volcast info: describes an Azure Kinect recording, an image sequence or (record_commands.cpp) a
// Volcast recording, checking every frame.
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>

#include "cli.hpp"
#include "commands.hpp"
#include "volcast/capture/source_summary.hpp"

namespace volcast {

// Exit code 0 whenever the source opens, bad frames or not: they are listed (and counted in
// bad_frame_count) for the reader to act on; 1 if the source cannot be opened at all.
int run_info(const InfoArgs& a) {
  if (std::filesystem::path(a.file).extension() == ".vcr") return run_recording_info(a);
  // Every frame is read once, with a progress line on stderr when a person watches (a terminal).
  const bool tty = isatty(STDERR_FILENO);
  int shown = -1;
  const SourceSummary s = summarize_source(a.file, [&](int done, int total) {
    const int percent = done * 100 / std::max(total, 1);
    if (!tty || percent == shown) return;
    shown = percent;
    std::fprintf(stderr, "\rchecking every frame: %d/%d (%d %%)", done, total, percent);
  });
  if (tty) std::fprintf(stderr, "\r\033[K");  // clear the progress line
  if (a.json)
    std::printf("%s\n", summary_json(s).c_str());
  else
    std::fputs(summary_text(s).c_str(), stdout);
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
