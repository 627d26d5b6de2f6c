#pragma once
// The volcast command line: each subcommand adds itself (its options, their defaults, help texts
// and checks) from its own file through a register_* function, and leaves main a Command to run
// when it is the one given.
#include <CLI/CLI.hpp>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace volcast {

struct FilterFlags;
struct ServeArgs;

/// A registered subcommand: `run` returns the process exit code (errors are thrown as
/// volcast::Error and reported by main); its arguments live in the closure.
struct Command {
  CLI::App* app = nullptr;
  std::function<int()> run;
};
using Commands = std::vector<Command>;

/// Adds subcommand `name` (`help` is what --help says of it) to `app` and its Command to
/// `commands`: `run(args)` on an `Args` that the subcommand's flags fill. Returns the subcommand,
/// to add those flags to, and the Args (the Command owns them).
template <typename Args, typename Run>
std::pair<CLI::App*, Args&> add_command(CLI::App& app, Commands& commands, Run run,
                                        const std::string& name, const std::string& help) {
  auto args = std::make_shared<Args>();
  CLI::App* sub = app.add_subcommand(name, help);
  commands.push_back({sub, [args, run] { return run(*args); }});
  return {sub, *args};
}

/// --low-latency's help text (serve, replay, relay, view, demo; bench --session prefixes it).
extern const std::string kLowLatencyHelp;
/// --token's help text (view, record).
extern const std::string kTokenHelp;

/// Filter flags shared by serve, replay, filter and background (the background flags only
/// `with_background`).
void add_filter_flags(CLI::App* app, FilterFlags& f, bool with_background);
/// --connect and --connect-file: one of them (connect_client_config reads them and says so if
/// neither is given).
void add_connect_flags(CLI::App* c, std::string& connect, std::string& connect_file);
/// The flags of every command that serves viewers (serve, replay, relay): the port, pacing,
/// security, the browser page and the NATS account.
void add_server_flags(CLI::App* s, ServeArgs& serve);
/// The flags serve and replay share (replay has no cameras to filter: it takes them too and
/// refuses them when given).
void add_serve_flags(CLI::App* s, ServeArgs& serve);

// One per subcommand, in the order `volcast --help` lists them.
void register_serve(CLI::App& app, Commands& commands);
void register_replay(CLI::App& app, Commands& commands);
void register_relay(CLI::App& app, Commands& commands);
void register_view(CLI::App& app, Commands& commands);
void register_demo(CLI::App& app, Commands& commands);
void register_filter(CLI::App& app, Commands& commands);
void register_background(CLI::App& app, Commands& commands);
void register_bench(CLI::App& app, Commands& commands);
void register_calibrate(CLI::App& app, Commands& commands);
void register_info(CLI::App& app, Commands& commands);
void register_record(CLI::App& app, Commands& commands);
void register_export(CLI::App& app, Commands& commands);
void register_case(CLI::App& app, Commands& commands);

}  // namespace volcast
