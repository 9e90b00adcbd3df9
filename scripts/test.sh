#!/usr/bin/env bash
# Installs what is missing, builds Release, runs every test (ctest: the C++ suites, the
# CLI tests, the pytest suite and the MPI tests are all registered with ctest).
# With VOXPACK_SANITIZER_STAGE=1 (set by .ci/run) a second build with ASan + UBSan runs the
# unit and CLI tests again (build-asan/; docs/reliability.md, "Sanitizers"), and with
# VOXPACK_FUZZ_STAGE=1 the libFuzzer targets run (build-fuzz/; "Fuzzing").
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${VOXPACK_BUILD_DIR:-$root/build}"
# ccache keys on paths relative to the checkout, so a fresh clone reuses the cache.
export CCACHE_BASEDIR="$root"
bash "$root/scripts/setup-deps.sh"
# The main build includes the MPI slab decomposition (tests run mpirun on loopback).
export VOXPACK_MPI="${VOXPACK_MPI:-ON}"
bash "$root/scripts/build.sh"
cd "$build"
ctest --output-on-failure -j "${VOXPACK_TEST_JOBS:-2}" --timeout 600
echo "test: results in $build/Testing"

if [[ "${VOXPACK_SANITIZER_STAGE:-0}" == "1" ]]; then
  asan="${VOXPACK_ASAN_BUILD_DIR:-$root/build-asan}"
  VOXPACK_BUILD_DIR="$asan" bash "$root/scripts/build.sh" -DVOXPACK_SANITIZE=address,undefined \
    -DVOXPACK_BUILD_BENCH=OFF -DVOXPACK_PYTHON=OFF -DVOXPACK_MPI=OFF
  cd "$asan"
  # LeakSanitizer under ptrace-less CI is fine; OpenMP's runtime keeps its pools alive.
  export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1"
  # Narrow suppressions for leaks inside system libraries, one reason each in the file.
  export LSAN_OPTIONS="suppressions=$root/scripts/lsan.supp"
  export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
  # Four DEM tests pass sanitized but take 37-102 s each there (whole pours at two thread
  # counts, a tapped bed, a convergence sweep); the other DEM tests run the same code.
  slow_dem="DemPack.TappingCompactsTheSettledPour|DemPack.IdenticalForAnyThreadCount"
  slow_dem+="|DemConvergence.SphereBedDensityAt10To20VoxelsPerDiameter"
  slow_dem+="|DemPack.NodeListsDoNotChangeTheForces"
  ctest --output-on-failure -j "${VOXPACK_TEST_JOBS:-2}" --timeout 900 -LE "no_sanitizer" \
    -E "$slow_dem"
  echo "test: sanitizer results in $asan/Testing"
fi

# The fuzz stage (VOXPACK_FUZZ_STAGE=1, set by .ci/run; docs/reliability.md, "Fuzzing"):
# clang-14 + libFuzzer + ASan/UBSan in build-fuzz/. First every saved input (the seed
# corpus and the fixed findings) once, then a short campaign per target of a fixed number
# of executions from a fixed seed, so the same commit fuzzes the same inputs every run.
# VOXPACK_FUZZ_TARGETS narrows the list, VOXPACK_FUZZ_RUNS sets the executions.
if [[ "${VOXPACK_FUZZ_STAGE:-0}" == "1" ]]; then
  read -r -a fuzz_targets <<<"${VOXPACK_FUZZ_TARGETS:-bed_reader stl scene image_header}"
  bash "$root/scripts/fuzz.sh" --regress "${fuzz_targets[@]}"
  VOXPACK_FUZZ_RUNS="${VOXPACK_FUZZ_RUNS:-2000}" bash "$root/scripts/fuzz.sh" 0 "${fuzz_targets[@]}"
  echo "test: fuzz results in ${VOXPACK_FUZZ_BUILD_DIR:-$root/build-fuzz}"
fi
