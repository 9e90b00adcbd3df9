#!/usr/bin/env bash
# Builds the libFuzzer targets (clang-14, ASan + UBSan + libFuzzer) in build-fuzz/ and runs
# each for SECONDS (default 60) on a working copy of its seed corpus (fuzz/corpus/NAME).
# Usage: scripts/fuzz.sh [SECONDS] [TARGET...]   e.g. scripts/fuzz.sh 600 stl scene
# Findings land in build-fuzz/artifacts/NAME/; the script exits 1 when there is any.
# The last libFuzzer status line of each run (execs, cov, ft, corpus) is printed and
# appended to build-fuzz/fuzz-runs.txt (docs/reliability.md records the campaign).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
seconds="${1:-60}"
shift || true
targets=("$@")
[[ ${#targets[@]} -eq 0 ]] && targets=(bed_reader stl scene image_header)
build="${VOXPACK_FUZZ_BUILD_DIR:-$root/build-fuzz}"
export CCACHE_BASEDIR="$root"
if [[ ! -f "$build/CMakeCache.txt" ]]; then
  CC=clang-14 CXX=clang++-14 cmake -S "$root" -B "$build" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DVOXPACK_FUZZ=ON -DVOXPACK_SANITIZE=address,undefined,fuzzer-no-link \
    -DVOXPACK_BUILD_TESTS=OFF -DVOXPACK_BUILD_BENCH=OFF -DVOXPACK_PYTHON=OFF -DVOXPACK_MPI=OFF \
    >/dev/null
fi
cmake --build "$build" -j "${VOXPACK_JOBS:-$(nproc)}" --target $(printf 'fuzz_%s ' "${targets[@]}")
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:allocator_may_return_null=1"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
found=0
for t in "${targets[@]}"; do
  corpus="$build/corpus/$t"
  artifacts="$build/artifacts/$t"
  mkdir -p "$corpus" "$artifacts"
  cp -n "$root/fuzz/corpus/$t/"* "$corpus/" 2>/dev/null || true
  log="$build/fuzz_$t.log"
  echo "fuzz: $t for ${seconds} s"
  # -timeout: one input may take at most 10 s (a hang is a finding); rss/malloc limits
  # make a huge allocation a finding instead of a dead machine.
  set +e
  "$build/bin/fuzz_$t" "$corpus" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
    -malloc_limit_mb=1024 -max_len=65536 -print_final_stats=1 -artifact_prefix="$artifacts/" \
    >"$log" 2>&1
  rc=$?
  set -e
  status="$(grep -E '^#[0-9]+' "$log" | tail -1 || true)"
  echo "  exit $rc; $status"
  echo "$(date -u +%FT%TZ) $t ${seconds}s exit=$rc $status" >>"$build/fuzz-runs.txt"
  if ls "$artifacts"/* >/dev/null 2>&1; then
    echo "  findings: $(ls "$artifacts" | tr '\n' ' ')"
    found=1
  fi
  rm -rf /tmp/voxpack_fuzz_* 2>/dev/null || true
done
exit "$found"
