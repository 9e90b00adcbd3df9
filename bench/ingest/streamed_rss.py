#!/usr/bin/python3
"""Peak RSS of streamed `voxpack ingest` against its memory estimate (docs/scale.md).

usage: streamed_rss.py VOXPACK WORKDIR OUT.json [--columns given,auto] [N ...]

For each N (default 256 384): an N^3 uint8 grey volume (bench/scale/make_grey_nrrd.py: sphere
tile in a column, noise 20, no blur), ingested with the column given (--columns: given, auto
= fitted on the stream, or both), under two memory limits
that make it stream (LIMITS), with --threshold otsu and the default (volume), on 1 and 2
threads. Peak RSS
from /usr/bin/time -v; the estimate and the slab planes from the report. One run each.
"""
import json
import os
import subprocess
import sys
import time

VOX, WORK, OUT = sys.argv[1], sys.argv[2], sys.argv[3]
REST = sys.argv[4:]
COLUMNS = ["given"]
if "--columns" in REST:
    i = REST.index("--columns")
    COLUMNS = REST[i + 1].split(",")
    del REST[i:i + 2]
SIZES = [int(a) for a in REST] or [256, 384]
LIMITS = {256: ("80M", "120M"), 384: ("128M", "256M")}
HERE = os.path.dirname(os.path.abspath(__file__))
os.makedirs(WORK, exist_ok=True)
rows = []
for n in SIZES:
    img = os.path.join(WORK, f"g{n}.nrrd")
    subprocess.run(["/usr/bin/python3", os.path.join(HERE, "..", "scale", "make_grey_nrrd.py"),
                    str(n), img, "1"], check=True)
    c = 0.5 * (n - 1) * 0.1
    given = f"{c},{c},{0.48 * n * 0.1}"
    for limit, column in [(l, k) for l in LIMITS.get(n, ("120M", "256M")) for k in COLUMNS]:
        for threshold in ("otsu", "auto"):
            for threads in (1, 2):
                out = os.path.join(WORK, "s.h5")
                t0 = time.time()
                p = subprocess.run(["/usr/bin/time", "-v", VOX, "-q", "--threads", str(threads),
                                    "--memory-limit", limit, "ingest", img, "-o", out,
                                    "--column", given if column == "given" else "auto",
                                    "--threshold", threshold, "--json"],
                                   capture_output=True, text=True)
                wall = time.time() - t0
                rss = next(int(l.split()[-1]) for l in p.stderr.splitlines()
                           if "Maximum resident" in l) * 1024
                rep = json.loads(p.stdout)
                s = rep["streamed"]
                row = dict(n=n, limit=limit, column=column, threshold=threshold,
                           method=rep["threshold"]["method"], threads=threads,
                           slab_planes=s["slab_planes"], slabs=s["slabs"], passes=s["passes"],
                           estimate_bytes=s["memory_estimate_bytes"], peak_rss_bytes=rss,
                           ratio=rss / s["memory_estimate_bytes"], wall_s=wall,
                           porosity=rep["porosity"],
                           radius_mm=rep["column"].get("radius_mm"),
                           column_refined=rep["column"].get("refined"))
                print(json.dumps(row), flush=True)
                rows.append(row)
    os.remove(img)
with open(OUT, "w") as f:
    json.dump(dict(description="peak RSS of streamed voxpack ingest against its estimate "
                               "(bench/ingest/streamed_rss.py; one run each)",
                   command=" ".join(sys.argv), load_average=os.getloadavg(), rows=rows),
              f, indent=1)
