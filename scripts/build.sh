#!/usr/bin/env bash
# Configures and builds voxpack (Release) in build/. Usage: scripts/build.sh [extra cmake args]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${VOXPACK_BUILD_DIR:-$root/build}"
jobs="${VOXPACK_JOBS:-$(nproc)}"
cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=Release \
  -DVOXPACK_STRICT="${VOXPACK_STRICT:-OFF}" -DVOXPACK_MPI="${VOXPACK_MPI:-OFF}" "$@" >/dev/null
cmake --build "$build" -j "$jobs"
echo "build: binary at $build/bin/voxpack"
