#!/usr/bin/env bash
# Second README command: install what is missing, build the sanitizer preset and run every test.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
cmake --preset dev
cmake --build --preset dev
ctest --preset dev -j2
