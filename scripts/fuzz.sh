#!/usr/bin/env bash
# Fuzzes every decoder and the protocol parsers with libFuzzer (the dev preset's build: Clang 14,
# ASan + UBSan, the same libraries the tests use) for FUZZ_SECONDS each (default 30), FUZZ_JOBS
# targets at a time (default: the number of cores). Part of the test command (scripts/test.sh).
# A finding stops the script with the fuzzer's report; the input that triggered it is saved as
# build/dev/fuzz/findings/crash-* (rerun: build/dev/fuzz/<target> build/dev/fuzz/findings/crash-...).
# The corpus of each target stays in build/dev/fuzz/corpus/<target> and grows from run to run.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${FUZZ_SECONDS:-30}"
jobs="${FUZZ_JOBS:-$(nproc)}"
export LSAN_OPTIONS="suppressions=$PWD/tests/support/lsan.supp"
[ -f build/dev/build.ninja ] || cmake --preset dev >/dev/null

mapfile -t targets < <(ninja -C build/dev -t targets all | sed -n 's|^fuzz/\(fuzz_[a-z0-9_]*\): .*|\1|p' | sort -u)
((${#targets[@]})) || { echo "fuzz: no fuzz targets in build/dev (is VOLCAST_FUZZ on?)"; exit 1; }
cmake --build build/dev --target "${targets[@]}"
out=build/dev/fuzz
mkdir -p "$out/findings"

# Runs one target; its log is $out/<target>.log. Exit status: the fuzzer's.
run_one() {
  local name="$1"
  mkdir -p "$out/corpus/$name"
  "$out/$name" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=4096 \
    -artifact_prefix="$out/findings/" "$out/corpus/$name" >"$out/$name.log" 2>&1
}

echo "fuzz: ${#targets[@]} targets, ${seconds} s each, ${jobs} at a time"
declare -A running=()  # pid -> target
failed=""
report() {  # $1 pid, $2 its exit status
  local name="${running[$1]}"
  unset "running[$1]"
  if [ "$2" -ne 0 ]; then
    grep -v '^#' "$out/$name.log" | tail -n 60
    echo "fuzz: $name found a problem (report above, full log $out/$name.log)"
    failed="$name"
  else
    echo "fuzz: $name: $(grep -E '^#[0-9]+.*DONE' "$out/$name.log" | tail -n 1)"
  fi
}
reap_one() {  # waits for one running target to end and reports it
  local done_pid status
  set +e
  wait -n -p done_pid "${!running[@]}"
  status=$?
  set -e
  report "$done_pid" "$status"
}
for name in "${targets[@]}"; do
  while ((${#running[@]} >= jobs)); do reap_one; done
  [ -z "$failed" ] || break
  run_one "$name" &
  running[$!]="$name"
done
while ((${#running[@]})); do reap_one; done
[ -z "$failed" ] || exit 1
echo "fuzz: every target ran ${seconds} s without a finding"
