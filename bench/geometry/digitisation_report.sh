#!/bin/sh
# Regenerates the numbers and the figure of docs/digitisation.md in one command:
#   bench/geometry/digitisation_report.sh [BUILD_DIR]   (default: build)
# Tables go to stdout; docs/figures/digitisation_sphere.{csv,png} are rewritten.
set -eu
here=$(cd "$(dirname "$0")/../.." && pwd)
build=${1:-$here/build}
cmake --build "$build" --target digitisation_sweep bench_digitise >/dev/null
"$build/bin/digitisation_sweep" "$here/docs/figures"
/usr/bin/python3 "$here/bench/geometry/plot_digitisation.py" "$here/docs/figures" >&2
echo
echo "## Digitisation speed (bench_digitise, CPU time per digitisation)"
echo
"$build/bin/bench_digitise" 1
