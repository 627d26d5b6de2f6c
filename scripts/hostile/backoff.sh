#!/usr/bin/env bash
# Issue 33 item 10, measured: 3 wrong join tokens from 127.0.0.1, then the right one at once (was it
# refused by the back-off?), then a 4th wrong one (is the back-off still there for wrong tokens?).
# usage: backoff.sh VOLCAST_BINARY
set -euo pipefail
if [ $# -ne 1 ]; then sed -n '2,4p' "$0" | sed 's/^# //' >&2; exit 2; fi
bin=$(realpath "$1")
here=$(cd "$(dirname "$0")" && pwd)
data=${VOLCAST_DATA:-$(realpath -m "$here/../../../shared/data")}
tmp=$(mktemp -d -t volcast-backoff.XXXXXX)
pid=
cleanup() {
  if [ -n "$pid" ] && kill -0 "$pid" 2>/dev/null; then kill "$pid"; wait "$pid" 2>/dev/null || true; fi
  rm -rf "$tmp"
}
trap cleanup EXIT
trap 'exit 130' INT TERM
export XDG_CONFIG_HOME=$tmp/config ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=0}

"$bin" serve --source "$data/rgbd-hands-640x360" --port 0 --bind 127.0.0.1 --fps 30 >"$tmp/serve.log" 2>&1 &
pid=$!
link=
for _ in $(seq 100); do
  link=$(grep -o 'volcast://[^ ]*' "$tmp/serve.log" | head -1 || true)
  [ -n "$link" ] && break
  kill -0 "$pid" 2>/dev/null || break
  sleep 0.2
done
if [ -z "$link" ]; then echo "volcast serve printed no join link:" >&2; cat "$tmp/serve.log" >&2; exit 1; fi
token=${link#*token=}; token=${token%%&*}
wrong=${link/token=$token/token=00000000000000000000000000000000}
for _ in 1 2 3; do
  { "$bin" view --connect "$wrong" --no-render --frames 1 2>&1 || true; } | grep -o "wrong join token[^:]*" | head -1 || true
done
start=$(date +%s.%N)
if "$bin" view --connect "$link" --no-render --frames 1 >"$tmp/view.log" 2>&1; then
  right="joined in $(awk -v a="$start" -v b="$(date +%s.%N)" 'BEGIN { printf "%.2f", b - a }') s"
else
  right="refused: $(grep -o 'try again[^"]*' "$tmp/view.log" | head -1 || true)"
fi
echo "right token: $right"
fourth=$({ "$bin" view --connect "$wrong" --no-render --frames 1 2>&1 || true; } |
         grep -o "try again in [0-9]* s\|wrong join token" | head -1 || true)
echo "4th wrong token: $fourth"
echo "summary (issue 33 item 10, right token after 3 wrong ones): right token $right; 4th wrong token: ${fourth:-no message}"
