#!/usr/bin/env bash
# The one test command: installs what is missing, builds, runs every test
# (unit, integration, end to end) with ctest.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
ctest --preset release -j 2 "$@"
