#!/usr/bin/env python3
"""Summary of bench/dem/scale.sh runs: one row per particle count, from the files the script
leaves in OUT_DIR (nN.time, nN.load, nN.info.json), written to OUT_DIR/dem_scale.json.
  scale_summary.py OUT_DIR "COUNTS" MAX_TIME_S THREADS
Costs per particle-step are wall seconds of the DEM loop over particles present x steps
(all, and the integrated = awake ones): the second is what a step pays for what moves."""
import json
import sys

out, counts, maxt, threads = sys.argv[1], sys.argv[2].split(), float(sys.argv[3]), int(sys.argv[4])
rows = []
for n in counts:
    b = f"{out}/n{n}"
    wall, user, rss = open(b + ".time").read().split()[-3:]
    info = json.load(open(b + ".info.json"))
    dem = info["provenance"]["dem"]
    ps, ips = dem["particle_steps"], dem["integrated_particle_steps"]
    rows.append({
        "count": int(n), "status": info["provenance"]["status"], "particles": info["particles"],
        "wall_s": float(wall), "cpu_user_s": float(user), "max_rss_kb": int(rss),
        "load_before_after": open(b + ".load").read().split("\n")[:2],
        "simulated_time_s": dem["simulated_time_s"], "steps": dem["steps"],
        "time_step_s": dem["time_step_s"],
        "stiffness_n_mm3": dem["stiffness_n_mm3"],
        "stiffness_load_height_mm": dem.get("stiffness_load_height_mm"),
        "dem_wall_time_s": dem["dem_wall_time_s"], "particle_steps": ps,
        "integrated_particle_steps": ips, "integrated_share": ips / max(1, ps),
        "neighbour_rebuilds": dem["neighbour_rebuilds"],
        "neighbour_rebuilds_partial": dem.get("neighbour_rebuilds_partial"),
        "mean_overlap_d": dem["mean_overlap_d"], "max_overlap_d": dem["max_overlap_d"],
        "interpenetrations": dem.get("interpenetrations"),
        "us_per_particle_step": 1e6 * dem["dem_wall_time_s"] / max(1, ps),
        "us_per_integrated_particle_step": 1e6 * dem["dem_wall_time_s"] / max(1, ips),
        "wall_s_per_simulated_s": dem["dem_wall_time_s"] / max(1e-12, dem["simulated_time_s"]),
    })
    r = rows[-1]
    print(f"{n}: {r['status']}, {r['wall_s']:.0f} s wall, {r['max_rss_kb'] / 1024:.0f} MiB, "
          f"{r['simulated_time_s']:.2f} s simulated ({r['wall_s_per_simulated_s']:.0f} s wall each), "
          f"{r['us_per_particle_step']:.3f} us per particle-step, "
          f"{r['us_per_integrated_particle_step']:.3f} per integrated one "
          f"({100 * r['integrated_share']:.0f} % integrated); overlap mean {r['mean_overlap_d']:.4f} d, "
          f"max {r['max_overlap_d']:.4f} d")
json.dump({"what": "multi-tube scale case (bench/dem/scale.sh)", "threads": threads,
           "max_time_s": maxt, "runs": rows}, open(f"{out}/dem_scale.json", "w"), indent=1)
