#!/usr/bin/env bash
# Second README command: install what is missing, build the dev preset once (Clang 14, ASan +
# UBSan: the volcast binary, the browser viewer, the tests and the fuzzers), run every test, then
# fuzz every decoder and parser for a bounded time. Prints the seconds of each phase at the end.
#
#   bash scripts/test.sh            everything (what CI runs)
#   bash scripts/test.sh --quick    the inner loop: an incremental build of the unit tests (and
#                                   the volcast binary they run), then those tests (ctest label
#                                   `unit`), no fuzzing
#   bash scripts/test.sh --label L  the same for the tests labelled L (unit, stream, session,
#                                   browser, cluster, cli, registration)
set -euo pipefail
cd "$(dirname "$0")/.."
label=""
case "${1:-}" in
  "") ;;
  --quick) label=unit ;;
  --label) label="${2:?--label needs one of: unit stream session browser cluster cli registration}" ;;
  *) echo "usage: bash scripts/test.sh [--quick | --label LABEL]" >&2; exit 2 ;;
esac

phases=()
started=$SECONDS
phase_done() { phases+=("$(printf '%-10s %5d s  %s' "$1" $((SECONDS - started)) "${2:-}")"); started=$SECONDS; }
summary() { echo "test.sh: seconds per phase"; printf '  %s\n' "${phases[@]}"; }
trap summary EXIT
# The compiler cache's hits and misses so far ("0 0" without ccache): the build's are the change.
ccache_counts() {
  command -v ccache >/dev/null || { echo "0 0"; return; }
  ccache --print-stats | awk '$1 == "direct_cache_hit" || $1 == "preprocessed_cache_hit" { h += $2 }
                              $1 == "cache_miss" { m += $2 } END { print h + 0, m + 0 }'
}

bash scripts/install-deps.sh
phase_done install
cmake --preset dev >/dev/null
phase_done configure
read -r hits0 misses0 < <(ccache_counts)
if [ -n "$label" ]; then
  cmake --build --preset dev --target "volcast_tests_$label"  # that label's tests and what they run
else
  cmake --build --preset dev
fi
read -r hits1 misses1 < <(ccache_counts)
hits=$((hits1 - hits0)) compiles=$((hits1 - hits0 + misses1 - misses0))
phase_done build "ccache: $hits of $compiles compiles hit ($((compiles ? 100 * hits / compiles : 0)) %)"
# The browser tests' npm packages (playwright-core, iwer), exactly as web/test/package-lock.json
# pins them; Chromium is Debian's (install-deps), never a download.
[ -n "$label" ] && [ "$label" != browser ] ||
  npm ci --prefix web/test --no-audit --no-fund --loglevel=error
phase_done npm
# One test more than cores: many tests wait part of their time (on a socket, a sound clock, a
# browser's page). On a 2-core machine (3c1d2cc, vmstat): -j2 839 s with the CPUs 94 % busy,
# -j3 771 s at 99 %. The heavy ones still run one at a time (the `heavy` lock, tests/CMakeLists.txt).
jobs=$(($(nproc) + 1))
if [ -n "$label" ]; then
  ctest --preset dev -L "^${label}\$" -j"$jobs"
  phase_done tests
  exit 0
fi
ctest --preset dev -j"$jobs"
phase_done tests
# libFuzzer on every decoder and the protocol parsers, FUZZ_SECONDS each, one per core.
FUZZ_SECONDS="${FUZZ_SECONDS:-10}" bash scripts/fuzz.sh
phase_done fuzz
