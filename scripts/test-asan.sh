#!/usr/bin/env bash
# The test suite again under AddressSanitizer + UndefinedBehaviorSanitizer (the asan
# preset, build/asan): any report fails its test. CI runs it after scripts/test.sh,
# which installs the packages. Left out: the container smoke test (it builds a
# release image), the fuzz test (its own clang ASan build) and the benchmarks.
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc 2>/dev/null || echo 2)
cmake --preset asan >/dev/null
cmake --build --preset asan -j "$jobs"
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:strict_string_checks=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
ctest --preset asan -j 2 -LE "container|fuzz" "$@"
