#!/usr/bin/env python3
"""bench_mes.sh's summary: per run the CPU per voxel, the plan, the estimate against the
peak RSS, and whether the streamed mean empty space equals the in-memory one.
Usage: mes_summary.py WORK OUT.json"""
import json, os, sys
work, path = sys.argv[1], sys.argv[2]
o = json.load(open(path)); n = o["n"]
ref = json.load(open(os.path.join(work, "mes_mem_%d.json" % n)))
strip = lambda m: {k: v for k, v in m.items() if k != "seconds"}
for r in o["runs"]:
    r["cpu_us_per_voxel"] = (r["user_s"] + r["sys_s"]) * 1e6 / r["voxels"]
    if r["run"].startswith("mes_streamed_"):
        j = json.load(open(os.path.join(work, "mes_%s_%d.json" % (r["run"][13:], n))))
        r["mes_equal_to_in_memory"] = strip(j["mes"]) == strip(ref["mes"])
        r["path"] = j["memory_estimate_bytes"]["path"]
        if "streamed" in j:
            r["plan"] = j["streamed"]["mes"]
            r["estimate_over_peak"] = j["streamed"]["mes"]["estimate_bytes"] / (1024.0 * r["peak_rss_kb"]) - 1
    elif r["run"] == "mes_in_memory":
        r["estimate_bytes"] = ref["memory_estimate_bytes"]["in_memory"]
        r["estimate_over_peak"] = r["estimate_bytes"] / (1024.0 * r["peak_rss_kb"]) - 1
        r["mean_mm"] = ref["mes"]["mean_mm"]; r["samples"] = ref["mes"]["samples"]
json.dump(o, open(path, "w"), indent=1)
