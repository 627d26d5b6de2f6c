#!/usr/bin/env bash
# First README command: install what is missing, build the release preset (the `volcast` binary
# and the browser viewer it serves with --web), run `volcast demo`.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
cmake --preset release
cmake --build --preset release --target volcast
./build/release/volcast demo --out out/demo "$@"
