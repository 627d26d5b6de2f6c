#!/usr/bin/env bash
# Starves a running process as a loaded machine may: stops it (SIGSTOP) for STOP_MS every
# PERIOD_MS until it exits. For checking that a real-time test (voice, streams) holds under load:
#
#   ./build/dev/tests/voice_session_test & bash scripts/stall.sh $! 400 100
set -euo pipefail
pid="${1:?usage: bash scripts/stall.sh PID PERIOD_MS STOP_MS}"
period_ms="${2:?usage: bash scripts/stall.sh PID PERIOD_MS STOP_MS}"
stop_ms="${3:?usage: bash scripts/stall.sh PID PERIOD_MS STOP_MS}"
seconds() { awk -v ms="$1" 'BEGIN { printf "%.3f", ms / 1000 }'; }
run_s=$(seconds "$period_ms")
stop_s=$(seconds "$stop_ms")
while kill -0 "$pid" 2>/dev/null; do
  sleep "$run_s"
  kill -STOP "$pid" 2>/dev/null || break
  sleep "$stop_s"
  kill -CONT "$pid" 2>/dev/null || break
done
