#!/usr/bin/env python3
"""Overhead of voxpack.stats from Python against `voxpack stats` on the same 256^3 bed.

    PYTHONPATH=build/python /usr/bin/python3 bench/python/bench_stats_overhead.py \
        --bin build/bin/voxpack [--size 256] [--repeats 3] [--threads 2] [--only ...]

The bed is synthetic (random overlapping balls of radius 8 voxels in a cylinder mask, seed 1,
0.2 mm voxels), written once with voxpack.write_bed. Each repeat runs, in alternating order:
  cli    the binary: `voxpack --quiet --threads T stats bed.h5 -o out.json` (a new process:
         start-up, HDF5 read + inflate, statistics, JSON write);
  array  voxpack.stats(indicator_array, mask=..., threads=T) in this process (one copy of the
         arrays into the C++ grids, statistics, JSON -> dict);
  path   voxpack.stats("bed.h5", threads=T) (read_bed, copy, statistics, dict).
Wall time (perf_counter), CPU time (user+sys of the child / of this process) and the 1-min
load average before and after are recorded per run (--wait-load L waits for load < L first); the overhead is median(python) / median(cli) - 1. The results must be
value for value equal (checked). Raw JSON to bench/results/python_overhead.json.
"""

import argparse
import json
import os
import pathlib
import resource
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

import voxpack


def make_bed(n: int, seed: int = 1):
    rng = np.random.default_rng(seed)
    void = np.ones((n, n, n), dtype=bool)
    r = 8
    ball = np.add.outer(np.add.outer(np.arange(-r, r + 1) ** 2, np.arange(-r, r + 1) ** 2),
                        np.arange(-r, r + 1) ** 2) <= r * r
    count = int(0.55 * n ** 3 / ball.sum())  # ~ 0.4 solid after overlaps
    for c in rng.integers(r, n - r, size=(count, 3)):
        z, y, x = c
        sub = void[z - r:z + r + 1, y - r:y + r + 1, x - r:x + r + 1]
        sub &= ~ball
    yy, xx = np.mgrid[0:n, 0:n]
    disc = (yy - (n - 1) / 2) ** 2 + (xx - (n - 1) / 2) ** 2 <= (n / 2) ** 2
    mask = np.broadcast_to(disc, (n, n, n)).astype(np.uint8)
    return void, mask


def cpu_self():
    u = resource.getrusage(resource.RUSAGE_SELF)
    return u.ru_utime + u.ru_stime


def cpu_children():
    u = resource.getrusage(resource.RUSAGE_CHILDREN)
    return u.ru_utime + u.ru_stime


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default="build/bin/voxpack")
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--only", default="", help="comma-separated statistics (default all)")
    ap.add_argument("--out", default="bench/results/python_overhead.json")
    ap.add_argument("--wait-load", type=float, default=0.0,
                    help="before each run, wait (up to --wait-max s) until the 1-min load is below this")
    ap.add_argument("--wait-max", type=float, default=120.0)
    a = ap.parse_args()

    tmp = pathlib.Path(tempfile.mkdtemp(prefix="voxpack-bench-"))
    void, mask = make_bed(a.size)
    bed_file = tmp / "bed.h5"
    voxpack.write_bed(bed_file, void, mask=mask, spacing_mm=0.2)
    only = [s for s in a.only.split(",") if s] or None
    flags = ["--only", a.only] if only else []
    runs = {"cli": [], "array": [], "path": []}
    load = {"before": os.getloadavg()}
    results = {}

    def run_cli():
        c0, t0 = cpu_children(), time.perf_counter()
        subprocess.run([a.bin, "--quiet", "--threads", str(a.threads), "stats", str(bed_file),
                        "-o", str(tmp / "cli.json"), *flags], check=True)
        return time.perf_counter() - t0, cpu_children() - c0

    def run_py(what):
        src = void if what == "array" else str(bed_file)
        kw = dict(mask=mask, spacing_mm=0.2) if what == "array" else {}
        c0, t0 = cpu_self(), time.perf_counter()
        results[what] = voxpack.stats(src, only=only, threads=a.threads, **kw)
        return time.perf_counter() - t0, cpu_self() - c0

    def wait_for_load():
        t0 = time.monotonic()
        while a.wait_load > 0 and os.getloadavg()[0] >= a.wait_load and time.monotonic() - t0 < a.wait_max:
            time.sleep(5)
        return time.monotonic() - t0

    for rep in range(a.repeats):
        order = ["cli", "array", "path"] if rep % 2 == 0 else ["path", "array", "cli"]
        for what in order:
            waited = wait_for_load()
            load_before = os.getloadavg()[0]
            wall, cpu = run_cli() if what == "cli" else run_py(what)
            runs[what].append({"wall_s": wall, "cpu_s": cpu, "load1_before": load_before,
                               "load1_after": os.getloadavg()[0], "waited_s": waited})
            print(f"repeat {rep} {what:5s} wall {wall:7.2f} s  cpu {cpu:7.2f} s  "
                  f"load {load_before:.2f}->{os.getloadavg()[0]:.2f}", flush=True)
        load["after"] = os.getloadavg()
        write_summary(a, tmp, bed_file, only, runs, load, results)
    for f in tmp.iterdir():
        f.unlink()
    tmp.rmdir()


def write_summary(a, tmp, bed_file, only, runs, load, results):

    ref = json.loads((tmp / "cli.json").read_text())
    drop = ("input", "command_line")
    timing = ("seconds", "memory_estimate_bytes", "packed_region")

    def clean(d):
        if isinstance(d, dict):
            return {k: clean(v) for k, v in d.items() if k not in drop + timing}
        return [clean(v) for v in d] if isinstance(d, list) else d
    equal = {w: clean(results[w]) == clean(ref) for w in ("array", "path")}

    def max_rel(x, y):
        """Largest relative difference of the numbers in two JSON trees (inf: structure)."""
        if isinstance(x, dict) and isinstance(y, dict):
            keys = set(x) | set(y)
            if any(k not in x or k not in y for k in keys):
                return float("inf")
            return max((max_rel(x[k], y[k]) for k in keys), default=0.0)
        if isinstance(x, list) and isinstance(y, list):
            if len(x) != len(y):
                return float("inf")
            return max((max_rel(u, v) for u, v in zip(x, y)), default=0.0)
        if isinstance(x, (int, float)) and isinstance(y, (int, float)) and not isinstance(x, bool):
            return abs(x - y) / max(abs(x), abs(y)) if x != y else 0.0
        return 0.0 if x == y else float("inf")
    # The array has no file provenance (the CLI's input_provenance is the file's).
    rel = {w: max_rel({k: v for k, v in clean(results[w]).items() if k != "input_provenance"},
                      {k: v for k, v in clean(ref).items() if k != "input_provenance"})
           for w in ("array", "path")}

    def med(what, key):
        return statistics.median(r[key] for r in runs[what])

    summary = {
        "what": "voxpack.stats from Python vs `voxpack stats` (new process) on the same bed",
        "bed": {"dims": [a.size] * 3, "spacing_mm": 0.2, "seed": 1,
                "structure": "random overlapping balls r=8 voxels, cylinder mask",
                "file_bytes": bed_file.stat().st_size},
        "statistics": only or "all",
        "threads": a.threads,
        "repeats": len(runs["cli"]),
        "runs": runs,
        "median_wall_s": {w: med(w, "wall_s") for w in runs},
        "median_cpu_s": {w: med(w, "cpu_s") for w in runs},
        "overhead_wall": {w: med(w, "wall_s") / med("cli", "wall_s") - 1 for w in ("array", "path")},
        "overhead_cpu": {w: med(w, "cpu_s") / med("cli", "cpu_s") - 1 for w in ("array", "path")},
        "results_equal_to_cli": equal,
        "results_max_rel_diff_to_cli": rel,
        "loadavg": load,
        "cpu_count": os.cpu_count(),
        "python": sys.version.split()[0],
        "voxpack": voxpack.__version__,
        "date_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    }
    out = pathlib.Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(summary, indent=2) + "\n")
    print(json.dumps({k: summary[k] for k in ("median_wall_s", "median_cpu_s", "overhead_wall",
                                              "overhead_cpu", "results_equal_to_cli",
                                              "results_max_rel_diff_to_cli", "loadavg")},
                     indent=2), flush=True)


if __name__ == "__main__":
    main()
