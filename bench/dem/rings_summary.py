#!/usr/bin/env python3
"""Summary of bench/dem/rings.sh: OUT_DIR/dem_rings.json from each run's check, provenance,
/usr/bin/time line and load.    rings_summary.py OUT_DIR THREADS"""
import json, sys
out, threads = sys.argv[1], int(sys.argv[2])
res = {"command": "bench/dem/rings.sh", "threads": threads, "runs": {}}
for name in ("rings", "trilobes"):
    wall, cpu, rss = open(f"{out}/{name}.time").read().split()
    load = [l.split() for l in open(f"{out}/{name}.load").read().splitlines()]
    info = json.load(open(f"{out}/{name}.info.json"))
    prov = info.get("provenance", {})
    dem = prov.get("dem", {})
    res["runs"][name] = {
        "check": json.load(open(f"{out}/{name}.check.json")),
        "command_line": prov.get("command_line"),
        "status": prov.get("status"),
        "wall_s": float(wall), "cpu_s": float(cpu), "max_rss_mib": int(rss) / 1024,
        "load_start_end": load,
        "dem": {k: dem.get(k) for k in ("interpenetrations", "max_overlap_wall_fraction",
                                        "max_overlap_wall_fraction_run", "interpenetrating_steps",
                                        "max_overlap_d", "mean_overlap_d", "contacts",
                                        "simulated_time_s", "steps", "stiffness_n_mm3")},
    }
json.dump(res, open(f"{out}/dem_rings.json", "w"), indent=1)
print(json.dumps({n: {"keep_min": r["check"]["keep"]["min"],
                      "voidage": r["check"]["voidage"]["voidage"],
                      "interpenetrations": r["dem"]["interpenetrations"],
                      "wall_s": r["wall_s"]} for n, r in res["runs"].items()}, indent=1))
