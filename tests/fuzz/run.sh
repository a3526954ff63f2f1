#!/bin/sh
# Builds the libFuzzer target config_fuzz with clang in its own build dir
# (default build/fuzz; only that target and what it links) and runs it for a
# bounded time. Usage: tests/fuzz/run.sh [SECONDS=30] [BUILD_DIR]
# Prints libFuzzer's final stats (executions); exits non-zero on a crash.
set -eu
seconds=${1:-30}
src=$(cd "$(dirname "$0")/../.." && pwd)
build=${2:-$src/build/fuzz}
CC=clang CXX=clang++ cmake -S "$src" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DEXCITE_BUILD_FUZZERS=ON -DEXCITE_BUILD_BENCH=OFF \
  -DCMAKE_CXX_FLAGS="-fsanitize=fuzzer-no-link,address" >"$build.configure.log" 2>&1 ||
  { cat "$build.configure.log"; exit 1; }
cmake --build "$build" -j2 --target config_fuzz
corpus=$build/fuzz-corpus
mkdir -p "$corpus"
cp "$src"/tests/fuzz/corpus/* "$corpus"/
"$build"/tests/fuzz/config_fuzz -max_total_time="$seconds" -print_final_stats=1 \
  -max_len=4096 "$corpus" 2>&1 | tee "$build/fuzz.log" | grep -E "stat::number_of_executed_units|Done|ERROR|SUMMARY" || true
# libFuzzer exits non-zero on a crash; tee hides it, so check the log.
if grep -q "ERROR: \|SUMMARY: " "$build/fuzz.log"; then exit 1; fi
