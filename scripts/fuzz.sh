#!/usr/bin/env bash
# Builds the libFuzzer targets (clang-14, ASan + UBSan + libFuzzer) in build-fuzz/ and runs
# each for SECONDS (default 60) on a working copy of its seed corpus (fuzz/corpus/NAME).
# Usage: scripts/fuzz.sh [SECONDS] [TARGET...]   e.g. scripts/fuzz.sh 600 stl scene
# Findings land in build-fuzz/artifacts/NAME/; the script exits 1 when there is any.
# The last libFuzzer status line of each run (execs, cov, ft, corpus) is printed and
# appended to build-fuzz/fuzz-runs.txt (docs/reliability.md records the campaign).
#
# scripts/fuzz.sh --regress [TARGET...] (for CI): builds the targets and runs each once over
# every file of fuzz/corpus/NAME and fuzz/findings/NAME (no fuzzing), with the same limits;
# exits 1 when any input crashes, leaks, times out or trips a sanitizer.
#
# VOXPACK_FUZZ_RUNS=N (the CI stage, scripts/test.sh): each target fuzzes for N executions
# from seed 1 (-runs=N -seed=1) instead of SECONDS, so a CI run is reproducible: the same
# commit mutates the same inputs, and a finding fails CI every time, not now and then.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
regress=0
if [[ "${1:-}" == "--regress" ]]; then
  regress=1
  shift
  seconds=0
else
  seconds="${1:-60}"
  shift || true
fi
targets=("$@")
[[ ${#targets[@]} -eq 0 ]] && targets=(bed_reader stl scene image_header)
build="${VOXPACK_FUZZ_BUILD_DIR:-$root/build-fuzz}"
export CCACHE_BASEDIR="$root"
# -g puts the build folder into the objects, and ccache then keys on it: without this a
# second fuzz build folder (e.g. a fresh one in CI) hits nothing of the first one's cache.
export CCACHE_NOHASHDIR=1
# Never -Werror here: VOXPACK_STRICT (CI) holds GCC's warnings; clang-14 warns on other
# things (e.g. -Wstring-concatenation on the report's deliberate caption literals), and
# the fuzz stage must test the code, not clang's warning set.
if [[ ! -f "$build/CMakeCache.txt" ]]; then
  VOXPACK_STRICT=OFF CC=clang-14 CXX=clang++-14 cmake -S "$root" -B "$build" \
    -DCMAKE_BUILD_TYPE=RelWithDebInfo -DVOXPACK_STRICT=OFF -DVOXPACK_FUZZ=ON -DVOXPACK_SANITIZE=address,undefined,fuzzer-no-link \
    -DVOXPACK_BUILD_TESTS=OFF -DVOXPACK_BUILD_BENCH=OFF -DVOXPACK_PYTHON=OFF -DVOXPACK_MPI=OFF \
    >/dev/null
fi
# VOXPACK_FUZZ_SKIP_BUILD=1 runs the binaries as built (e.g. while another run builds).
if [[ "${VOXPACK_FUZZ_SKIP_BUILD:-0}" != 1 ]]; then
  cmake --build "$build" -j "${VOXPACK_JOBS:-$(nproc)}" --target $(printf 'fuzz_%s ' "${targets[@]}")
fi
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:allocator_may_return_null=1:fast_unwind_on_malloc=0"
export LSAN_OPTIONS="suppressions=$root/fuzz/lsan.supp"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
# One allocation above 1 GiB, an RSS above 2 GiB or 10 s on one input is a finding.
# bed_reader: libhdf5 1.10 allocates an object-header chunk of the size the file declares
# before it finds the chunk past the end of the file (fuzz/findings/bed_reader/oom-db60...,
# docs/reliability.md); the allocation is never touched, so there only the RSS counts.
limitsFor() {
  local malloc=1024
  [[ $1 == bed_reader ]] && malloc=$((1 << 24))
  echo -timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=$malloc
}
# Scratch folders (fuzz_common.hpp) of fuzzer processes that have ended; those of a target
# still running (another run, or the children of -fork) stay.
cleanScratch() {
  local d
  for d in /tmp/voxpack_fuzz_*; do
    [[ -d $d ]] && ! kill -0 "${d##*_}" 2>/dev/null && rm -rf "$d"
  done
  return 0
}
# VOXPACK_FUZZ_KEEP_GOING=1: run in a child process (-fork=1) that is restarted after a
# crash, leak, timeout or OOM, so one run collects every finding of its time.
keepGoing=()
[[ "${VOXPACK_FUZZ_KEEP_GOING:-0}" == 1 ]] &&
  keepGoing=(-fork=1 -ignore_crashes=1 -ignore_timeouts=1 -ignore_ooms=1)
found=0
if [[ $regress -eq 1 ]]; then
  for t in "${targets[@]}"; do
    shopt -s nullglob
    inputs=("$root/fuzz/corpus/$t/"* "$root/fuzz/findings/$t/"*)
    shopt -u nullglob
    artifacts="$build/artifacts-regress/$t"
    mkdir -p "$artifacts"
    log="$build/regress_$t.log"
    set +e
    "$build/bin/fuzz_$t" $(limitsFor "$t") -artifact_prefix="$artifacts/" "${inputs[@]}" >"$log" 2>&1 &
    pid=$!
    wait "$pid"
    rc=$?
    set -e
    cleanScratch
    echo "fuzz --regress: $t: $(grep -c '^Executed ' "$log") inputs, exit $rc"
    if [[ $rc -ne 0 ]]; then
      tail -40 "$log"
      found=1
    fi
  done
  exit "$found"
fi
for t in "${targets[@]}"; do
  corpus="$build/corpus/$t"
  artifacts="$build/artifacts/$t"
  mkdir -p "$corpus" "$artifacts"
  cp -n "$root/fuzz/corpus/$t/"* "$corpus/" 2>/dev/null || true
  log="$build/fuzz_$t.log"
  budget=(-max_total_time="$seconds")
  [[ -n "${VOXPACK_FUZZ_RUNS:-}" ]] && budget=(-runs="$VOXPACK_FUZZ_RUNS" -seed=1)
  echo "fuzz: $t for ${budget[*]}"
  set +e
  "$build/bin/fuzz_$t" "$corpus" "${budget[@]}" $(limitsFor "$t") "${keepGoing[@]}" -max_len=65536 \
    -print_final_stats=1 -artifact_prefix="$artifacts/" >"$log" 2>&1 &
  pid=$!
  wait "$pid"
  rc=$?
  set -e
  cleanScratch
  status="$(grep -E '^#[0-9]+' "$log" | tail -1 || true)"
  [[ ${#keepGoing[@]} -gt 0 ]] && status="$(grep -E '^#[0-9]+: cov' "$log" | tail -1 || true)"
  echo "  exit $rc; $status"
  echo "$(date -u +%FT%TZ) $t ${budget[*]} exit=$rc load=$(cut -d' ' -f1-3 /proc/loadavg | tr ' ' /)" \
    "$status" >>"$build/fuzz-runs.txt"
  if ls "$artifacts"/* >/dev/null 2>&1; then
    echo "  findings: $(ls "$artifacts" | tr '\n' ' ')"
    found=1
  fi
done
exit "$found"
