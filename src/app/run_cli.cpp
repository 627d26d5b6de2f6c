// The volcast command line: the subcommands in the order --help lists them, parsed and run.
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <csignal>

#include "cli.hpp"
#include "commands.hpp"
#include "run_cli.hpp"
#include "volcast/codec_video/video_codecs.hpp"

namespace volcast {

int run_cli(int argc, char** argv) {
  std::signal(SIGINT, [](int) { g_interrupted = true; });
  std::signal(SIGTERM, [](int) { g_interrupted = true; });
  std::signal(SIGPIPE, SIG_IGN);
  // Logs go to stderr: stdout carries results (info's text and --json, the viewer's table).
  spdlog::set_default_logger(std::make_shared<spdlog::logger>(
      "", std::make_shared<spdlog::sinks::stderr_color_sink_mt>()));
  register_video_codecs();  // h264 and hevc join the codec table before anything looks one up

  CLI::App app{"volcast: stream RGB-D cameras to remote viewers as live point clouds"};
  app.require_subcommand(1);
  bool verbose = false;
  app.add_flag("-v,--verbose", verbose, "Log debug messages");
  Commands commands;
  for (const auto add :
       {register_serve, register_replay, register_relay, register_view, register_demo,
        register_filter, register_background, register_bench, register_calibrate, register_info,
        register_record, register_export, register_case})
    add(app, commands);

  CLI11_PARSE(app, argc, argv);
  if (verbose) spdlog::set_level(spdlog::level::debug);
  try {
    for (const Command& c : commands)
      if (*c.app) return c.run();
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 1;
}

}  // namespace volcast
