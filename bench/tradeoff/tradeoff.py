"""Speed/accuracy sweep of voxpack (issue 9). Run through bench/tradeoff.sh.

For each scene x mode x voxels-per-diameter x seed it runs `voxpack pack` under
/usr/bin/time -v (wall time, peak memory), `voxpack shape --json` at random orientations
(digitisation volume error), `voxpack stats` (packing density) and `voxpack compare` with the
finest run of the same scene and mode as the reference (radial-profile and S2 distances).
"""
import argparse
import csv
import json
import math
import os
import re
import subprocess
import sys
import time

# Scenes are sized so the whole sweep fits an evening on 2 cores: the paper's pellet
# (cylinders d 5.4, l 3.8) and spheres, in narrower columns (D/d = 4) than the paper's so a
# bed of ~100-200 particles still leaves several diameters of core after trimming one
# diameter at each end.
SCENES = {
    "cylinders": {"shape": "cylinder:d=5.4,l=3.8", "d": 5.4, "container": "cylinder:d=21.6,h={h}",
                  "count": 100, "height": 70.0},
    "spheres": {"shape": "sphere:d=3", "d": 3.0, "container": "cylinder:d=12,h={h}",
                "count": 200, "height": 60.0},
}
FULL = {"vpd": [6, 8, 10, 15, 20, 30], "seeds": [1, 2, 3], "modes": ["mc", "dem"],
        "scenes": ["cylinders", "spheres"]}
QUICK = {"vpd": [6, 10, 15], "seeds": [1], "modes": ["mc", "dem"], "scenes": ["spheres"],
         "count_scale": 0.5}


def run(cmd, log, timeout):
    t0 = time.monotonic()
    p = subprocess.run(["/usr/bin/time", "-v"] + cmd, capture_output=True, text=True,
                       timeout=timeout)
    wall = time.monotonic() - t0
    log.write("$ " + " ".join(cmd) + "\n" + p.stdout + p.stderr + "\n")
    log.flush()
    m = re.search(r"Maximum resident set size \(kbytes\): (\d+)", p.stderr)
    rss_mb = int(m.group(1)) / 1024.0 if m else float("nan")
    return p.returncode, wall, rss_mb, p.stdout


def shape_error(voxpack, spec, voxel, n=12):
    """Mean |relative volume error| over n fixed pseudo-random orientations."""
    errs = []
    for k in range(n):
        # Deterministic orientations spread over SO(3) (golden-angle axis, varying angle).
        phi = k * 2.399963
        z = 1 - 2 * (k + 0.5) / n
        r = math.sqrt(max(0.0, 1 - z * z))
        ax = (r * math.cos(phi), r * math.sin(phi), z)
        ang = 0.37 + 2.1 * k
        w, s = math.cos(ang / 2), math.sin(ang / 2)
        q = f"{w},{s*ax[0]},{s*ax[1]},{s*ax[2]}"
        out = subprocess.run([voxpack, "shape", "--shape", spec, "--voxel-size", f"{voxel}",
                              "--orientation", q, "--json"], capture_output=True, text=True)
        if out.returncode == 0:
            errs.append(abs(json.loads(out.stdout)["volume_rel_error"]))
    return sum(errs) / len(errs) if errs else float("nan")


def mean_std(v):
    v = [x for x in v if x is not None and not math.isnan(x)]
    if not v:
        return float("nan"), float("nan")
    m = sum(v) / len(v)
    s = math.sqrt(sum((x - m) ** 2 for x in v) / (len(v) - 1)) if len(v) > 1 else 0.0
    return m, s


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--voxpack", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--timeout", type=float, default=3600)
    ap.add_argument("--scenes", default="")
    ap.add_argument("--modes", default="")
    ap.add_argument("--vpd", default="")
    ap.add_argument("--seeds", default="")
    # One thread per run by default: timings then do not depend on what else the machine runs
    # (an OpenMP team on an oversubscribed machine can be 10x slower) and CPU = wall.
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--combine", default="",
                    help="comma-separated output dirs of earlier sweeps: merge their tables "
                         "and plots into --out without running anything")
    a = ap.parse_args()
    if a.combine:
        combine(a.out, a.combine.split(","))
        return
    plan = dict(QUICK if a.quick else FULL)
    if a.scenes:
        plan["scenes"] = a.scenes.split(",")
    if a.modes:
        plan["modes"] = a.modes.split(",")
    if a.vpd:
        plan["vpd"] = [float(x) for x in a.vpd.split(",")]
    if a.seeds:
        plan["seeds"] = [int(x) for x in a.seeds.split(",")]
    plan["threads"] = a.threads
    os.makedirs(a.out, exist_ok=True)
    beds = os.path.join(a.out, "beds")
    os.makedirs(beds, exist_ok=True)
    log = open(os.path.join(a.out, "tradeoff.log"), "w")
    rows = []
    t_start = time.monotonic()
    for scene_name in plan["scenes"]:
        sc = SCENES[scene_name]
        count = max(8, int(round(sc["count"] * plan.get("count_scale", 1.0))))
        height = sc["height"] * plan.get("count_scale", 1.0)
        container = sc["container"].format(h=f"{height:g}")
        for mode in plan["modes"]:
            for vpd in plan["vpd"]:
                voxel = sc["d"] / vpd
                err = shape_error(a.voxpack, sc["shape"], voxel)
                for seed in plan["seeds"]:
                    bed = os.path.join(beds, f"{scene_name}_{mode}_{vpd:g}_{seed}.h5")
                    cmd = [a.voxpack, "--quiet", "--threads", str(a.threads), "pack", "--mode", mode, "--shape", sc["shape"],
                           "--container", container, "--voxel-size", f"{voxel:.6g}",
                           "--count", str(count), "--seed", str(seed), "-o", bed]
                    try:
                        rc, wall, rss, _ = run(cmd, log, a.timeout)
                    except subprocess.TimeoutExpired:
                        rc, wall, rss = 124, a.timeout, float("nan")
                    row = {"scene": scene_name, "mode": mode, "vpd": vpd, "voxel_mm": voxel,
                           "seed": seed, "count": count, "exit": rc, "wall_s": wall,
                           "peak_mb": rss, "volume_error": err, "density": None,
                           "density_std": None, "radial_rmse": None, "s2_rmse": None,
                           "status": None, "bed": bed}
                    if rc == 0:
                        sj = os.path.join(beds, os.path.basename(bed)[:-3] + "_stats.json")
                        r2, _, _, _ = run([a.voxpack, "--quiet", "--threads", str(a.threads), "stats", bed, "-o", sj,
                                           "--only", "axial", "--particle-diameter-mm",
                                           f"{sc['d']}", "--trim-mm", f"{sc['d']}"], log, a.timeout)
                        if r2 == 0:
                            st = json.load(open(sj))
                            row["density"] = st["axial"]["mean"]
                            row["density_std"] = st["axial"]["std"]
                        info = subprocess.run([a.voxpack, "info", bed, "--json"],
                                              capture_output=True, text=True)
                        if info.returncode == 0:
                            prov = json.loads(info.stdout).get("provenance", {})
                            row["status"] = (prov.get(mode, {}) or {}).get("status",
                                                                          prov.get("status"))
                    rows.append(row)
                    print(f"[{time.monotonic()-t_start:7.0f}s] {scene_name} {mode} vpd={vpd:g} "
                          f"seed={seed}: exit {rc}, {wall:.1f} s, {rss:.0f} MB, "
                          f"density {row['density']}, status {row['status']}", flush=True)
            # Distances to the finest run of this scene and mode (same seed).
            finest = max(plan["vpd"])
            for seed in plan["seeds"]:
                ref = os.path.join(beds, f"{scene_name}_{mode}_{finest:g}_{seed}.h5")
                cands = [r for r in rows if r["scene"] == scene_name and r["mode"] == mode and
                         r["seed"] == seed and r["exit"] == 0 and r["vpd"] != finest]
                if not os.path.exists(ref) or not cands:
                    continue
                cdir = os.path.join(a.out, f"compare_{scene_name}_{mode}_{seed}")
                rc, _, _, _ = run([a.voxpack, "--quiet", "--threads", str(a.threads), "compare", "--reference", ref] +
                                  [c["bed"] for c in cands] +
                                  ["-o", cdir, "--no-figures", "--particle-diameter",
                                   f"{sc['d']}"], log, a.timeout)
                if rc != 0:
                    continue
                summ = json.load(open(os.path.join(cdir, "summary.json")))
                for c, s in zip(cands, summ["candidates"]):
                    c["radial_rmse"] = s.get("radial_rmse")
                    c["s2_rmse"] = s.get("s2_rmse")
    # Aggregate over seeds.
    agg = []
    keys = sorted({(r["scene"], r["mode"], r["vpd"]) for r in rows},
                  key=lambda k: (k[0], k[1], k[2]))
    for scene_name, mode, vpd in keys:
        g = [r for r in rows if (r["scene"], r["mode"], r["vpd"]) == (scene_name, mode, vpd)]
        ok = [r for r in g if r["exit"] == 0]
        dm, ds = mean_std([r["density"] for r in ok])
        agg.append({"scene": scene_name, "mode": mode, "vpd": vpd, "voxel_mm": g[0]["voxel_mm"],
                    "runs": len(g), "ok": len(ok),
                    "wall_s": mean_std([r["wall_s"] for r in ok])[0],
                    "peak_mb": max([r["peak_mb"] for r in ok], default=float("nan")),
                    "volume_error": g[0]["volume_error"], "density_mean": dm, "density_std": ds,
                    "radial_rmse": mean_std([r["radial_rmse"] for r in ok])[0],
                    "s2_rmse": mean_std([r["s2_rmse"] for r in ok])[0]})

    def clean(x):
        return None if isinstance(x, float) and (math.isnan(x) or math.isinf(x)) else x
    with open(os.path.join(a.out, "tradeoff.json"), "w") as f:
        json.dump({"plan": plan, "runs": [{k: clean(v) for k, v in r.items()} for r in rows],
                   "summary": [{k: clean(v) for k, v in r.items()} for r in agg]}, f, indent=2)
    with open(os.path.join(a.out, "tradeoff.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(agg[0].keys()) if agg else ["scene"])
        w.writeheader()
        for r in agg:
            w.writerow(r)
    write_markdown(a.out, agg, plan, time.monotonic() - t_start)
    try:
        plot(a.out, agg)
    except Exception as e:  # plots are a convenience; the numbers are already written
        print(f"warning: no plots ({e})", file=sys.stderr)
    print(f"tradeoff: {len(rows)} runs in {time.monotonic()-t_start:.0f} s; results in {a.out}")


def combine(out, dirs):
    """One table, CSV and figure from several sweeps (e.g. the MC and the DEM half)."""
    agg, plans = [], []
    for d in dirs:
        j = json.load(open(os.path.join(d, "tradeoff.json")))
        plans.append(j["plan"])
        agg += [{k: (float("nan") if v is None else v) for k, v in r.items()} for r in j["summary"]]
    agg.sort(key=lambda r: (r["scene"], r["mode"], r["vpd"]))
    os.makedirs(out, exist_ok=True)
    with open(os.path.join(out, "tradeoff.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(agg[0].keys()))
        w.writeheader()
        for r in agg:
            w.writerow(r)
    write_markdown(out, agg, {"combined": plans}, float("nan"))
    plot(out, agg)
    print(f"tradeoff: combined {len(agg)} rows from {len(dirs)} sweeps into {out}")


def fmt(x, spec):
    return "–" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)


def write_markdown(out, agg, plan, total):
    lines = ["| scene | mode | voxels/d | voxel mm | runs ok | wall s | peak MB | vol. error | "
             "density (mean ± std over seeds) | radial RMSE | S2 RMSE |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in agg:
        lines.append(f"| {r['scene']} | {r['mode']} | {r['vpd']:g} | {r['voxel_mm']:.3f} | "
                     f"{r['ok']}/{r['runs']} | {fmt(r['wall_s'], '.1f')} | "
                     f"{fmt(r['peak_mb'], '.0f')} | {fmt(r['volume_error'], '.4f')} | "
                     f"{fmt(r['density_mean'], '.4f')} ± {fmt(r['density_std'], '.4f')} | "
                     f"{fmt(r['radial_rmse'], '.4f')} | {fmt(r['s2_rmse'], '.5f')} |")
    lines.append("")
    lines.append(f"Total wall time of the sweep: {fmt(total, '.0f')} s. Plan: {json.dumps(plan)}")
    with open(os.path.join(out, "tradeoff_table.md"), "w") as f:
        f.write("\n".join(lines) + "\n")


def plot(out, agg):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
    for scene in sorted({r["scene"] for r in agg}):
        for mode in sorted({r["mode"] for r in agg}):
            g = [r for r in agg if r["scene"] == scene and r["mode"] == mode]
            if not g:
                continue
            x = [r["vpd"] for r in g]
            lab = f"{scene} {mode}"
            axes[0].plot(x, [r["wall_s"] for r in g], "o-", label=lab)
            axes[1].errorbar(x, [r["density_mean"] for r in g],
                             yerr=[r["density_std"] or 0 for r in g], fmt="o-", label=lab,
                             capsize=3)
            axes[2].plot(x, [r["s2_rmse"] for r in g], "o-", label=lab)
    axes[0].set_yscale("log")
    axes[0].set_ylabel("wall time (s)")
    axes[1].set_ylabel("packing density")
    axes[2].set_ylabel("S2 RMSE to finest run")
    for ax in axes:
        ax.set_xlabel("voxels per particle diameter")
        ax.grid(alpha=0.3)
    axes[1].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "tradeoff.png"), dpi=110)


if __name__ == "__main__":
    main()
