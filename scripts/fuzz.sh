#!/usr/bin/env bash
# Fuzzes every decoder and the protocol parsers with libFuzzer (Clang 14, ASan + UBSan) for a
# bounded time each: FUZZ_SECONDS (default 30). Part of the test command (scripts/test.sh).
# A finding stops the script with the fuzzer's report; the input that triggered it is saved as
# build/fuzz/findings/crash-* (rerun: build/fuzz/fuzz/<target> build/fuzz/findings/crash-...).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${FUZZ_SECONDS:-30}"
export LSAN_OPTIONS="suppressions=$PWD/tests/lsan.supp"
cmake -S . -B build/fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++-14 \
  -DCMAKE_C_COMPILER=clang-14 -DVOLCAST_FUZZ=ON -DVOLCAST_WERROR=ON >/dev/null
cmake --build build/fuzz
mkdir -p build/fuzz/findings
for target in build/fuzz/fuzz/fuzz_*; do
  name="$(basename "$target")"
  echo "fuzz: $name for ${seconds} s"
  mkdir -p "build/fuzz/corpus/$name"
  if ! "$target" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=4096 \
    -artifact_prefix=build/fuzz/findings/ "build/fuzz/corpus/$name" >build/fuzz/"$name".log 2>&1; then
    grep -v '^#' build/fuzz/"$name".log | tail -n 60
    echo "fuzz: $name found a problem (report above, full log build/fuzz/$name.log)"
    exit 1
  fi
  grep -E '^#[0-9]+.*DONE' build/fuzz/"$name".log | tail -n 1
done
echo "fuzz: every target ran ${seconds} s without a finding"
