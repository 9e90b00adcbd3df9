#!/usr/bin/env bash
# Installs what is missing, builds Release, runs every test (ctest).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${VOXPACK_BUILD_DIR:-$root/build}"
bash "$root/scripts/setup-deps.sh"
bash "$root/scripts/build.sh"
cd "$build"
ctest --output-on-failure -j "${VOXPACK_TEST_JOBS:-2}" --timeout 600
echo "test: results in $build/Testing"
