// volcast: live RGB-D streaming for VR telepresence. One executable, one subcommand per task; each
// subcommand registers itself from its own file (src/app/cli.hpp).
#include "run_cli.hpp"

int main(int argc, char** argv) {
  return volcast::run_cli(argc, argv);
}
