#!/usr/bin/env bash
# Second README command: install what is missing, build the sanitizer preset, run every test,
# then fuzz every decoder for a bounded time.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
cmake --preset dev
cmake --build --preset dev
# The browser tests' npm packages (playwright-core, iwer), exactly as web/test/package-lock.json
# pins them; Chromium is Debian's (install-deps), never a download.
npm ci --prefix web/test --no-audit --no-fund --loglevel=error
ctest --preset dev -j2
# libFuzzer on every decoder and the protocol parsers, FUZZ_SECONDS (default 30) each.
bash scripts/fuzz.sh
