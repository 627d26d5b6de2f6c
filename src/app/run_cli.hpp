#pragma once
// The volcast command line, apart from main() so that the executable's one file compiles in a
// moment (CLI11 and the subcommands' headers are parsed once, in volcast_app's precompiled header).

namespace volcast {

/// Sets up logging and signals, parses `argv` (each subcommand registered from its own file,
/// cli.hpp) and runs the subcommand given. Returns the process exit code: the subcommand's, 1 when
/// it threw (its error is logged), CLI11's for a parse error or --help.
int run_cli(int argc, char** argv);

}  // namespace volcast
