#!/usr/bin/env bash
# Issue 33 item 6, measured: serves the hands sequence at 30 fps on loopback (TLS, a free port); an
# honest viewer (volcast/jpeg, no render) watches for SECONDS (default 12); 2 s in, a greedy token
# holder asks for the tiers in $TIERS (default: the 8 costliest, hevc/h264 at quality 10..80;
# TIERS= for none, the baseline), each with `volcast record` (which does not decode) until the end.
# Prints the server's CPU from second 4 to the end (% of all cores), the honest viewer's frame rate
# (from --stats-json) and how many of the greedy tiers the server rejected.
# usage: greedy_tiers.sh VOLCAST_BINARY [SECONDS [serve flags...]]
set -euo pipefail
if [ $# -lt 1 ]; then sed -n '8p' "$0" | sed 's/^# //' >&2; exit 2; fi
V=$(realpath "$1"); S=${2:-12}; shift; [ $# -gt 0 ] && shift
if ! awk -v s="$S" 'BEGIN { exit !(s >= 5) }'; then echo "SECONDS must be at least 5" >&2; exit 2; fi
here=$(cd "$(dirname "$0")" && pwd)
DATA=${VOLCAST_DATA:-$(realpath -m "$here/../../../shared/data")}/rgbd-hands-640x360
OUT=$(mktemp -d -t volcast-greedy.XXXXXX)
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  for p in "${pids[@]}"; do wait "$p" 2>/dev/null || true; done
  rm -rf "$OUT"
}
trap cleanup EXIT
trap 'exit 130' INT TERM
export XDG_CONFIG_HOME=$OUT/config ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=0}

"$V" serve --source "$DATA" --fps 30 --port 0 --intrinsics 460,460,320,180 "$@" >"$OUT/serve.out" 2>"$OUT/serve.err" &
SP=$!; pids+=("$SP")
LINK=
for _ in $(seq 100); do
  LINK=$(cat "$OUT/serve.out" "$OUT/serve.err" | grep -o "volcast://[^ ]*" | head -1 || true)
  [ -n "$LINK" ] && break
  kill -0 "$SP" 2>/dev/null || break
  sleep 0.2
done
if [ -z "$LINK" ]; then echo "volcast serve printed no join link:" >&2; cat "$OUT/serve.err" >&2; exit 1; fi
echo "link: $LINK"
"$V" view --connect "$LINK" --no-render --seconds "$S" --stats-json "$OUT/honest.json" >"$OUT/honest.out" 2>&1 &
HP=$!; pids+=("$HP")
sleep 2
TIERS=${TIERS-hevc/h264/10 hevc/h264/20 hevc/h264/30 hevc/h264/40 hevc/h264/50 hevc/h264/60 hevc/h264/70 hevc/h264/80}
k=0
for t in $TIERS; do
  k=$((k+1))
  "$V" record --connect "$LINK" --tier "$t" --out "$OUT/greedy$k.vcr" --seconds "$(awk -v s="$S" 'BEGIN { print s - 2 }')" \
    --overwrite >"$OUT/greedy$k.out" 2>&1 &
  pids+=("$!")
done
sleep 2
t0=$(awk '{print $14+$15}' "/proc/$SP/stat"); s0=$(date +%s.%N)
sleep "$(awk -v s="$S" 'BEGIN { print s - 4 }')"
t1=$(awk '{print $14+$15}' "/proc/$SP/stat"); s1=$(date +%s.%N)
wait "$HP" || true
kill -INT "$SP"; wait "$SP" || true
HZ=$(getconf CLK_TCK); N=$(nproc)
cpu=$(awk -v a="$t0" -v b="$t1" -v hz="$HZ" -v s0="$s0" -v s1="$s1" -v n="$N" \
      'BEGIN { printf "%.1f", 100 * (b - a) / hz / (s1 - s0) / n }')
echo "server CPU: $cpu % of $N cores"
python3 - "$OUT" "$k" "$cpu" "$N" "$S" <<'PY'
import glob, json, sys
d, k, cpu, n, s = sys.argv[1:]
try:
    j = json.load(open(d + '/honest.json'))
    cam = j['cameras'][0]
    honest = '%d frame sets, %.1f fps received, latency p50 %.0f ms, ended %s' % (
        j['frame_sets_received'], cam['received_fps'], cam['latency_ms_p50'], j['ended'])
except (OSError, ValueError, KeyError, IndexError) as e:
    honest = 'no stats (%s): %s' % (e, open(d + '/honest.out').read()[-300:].strip())
outs = glob.glob(d + '/greedy*.out')
rej = sum('rejected' in open(f).read() for f in outs)
print('honest: ' + honest)
print('greedy: %d of %d tiers rejected' % (rej, len(outs)))
print('summary (issue 33 item 6, %s greedy tiers, %s s): server CPU %s %% of %s cores; honest viewer %s; '
      'greedy tiers rejected: %d of %d' % (k, s, cpu, n, honest, rej, len(outs)))
PY
