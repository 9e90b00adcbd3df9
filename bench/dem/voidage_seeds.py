#!/usr/bin/python3
"""Mean voidage per D/d and friction over seeds (docs/dem.md, "Mean voidage against Benyahia
& O'Neill"): mean, sd and each seed's value against eps = 0.390 + 1.740 / (D/d + 1.140)^2.

usage: voidage_seeds.py RESULTS.json... (each a bench/dem/fidelity.sh dem_fidelity.json, one
seed per file, in seed order) -> a markdown table on stdout
"""
import json
import sys

import numpy as np


def benyahia(r):
    return 0.390 + 1.740 / (r + 1.140) ** 2


per = {}  # name -> list of voidages, one per file
for n, path in enumerate(sys.argv[1:]):
    for b in json.load(open(path))["beds"]:
        if b["name"].startswith("voidage") and "structure" in b:
            per.setdefault(b["name"], [None] * (len(sys.argv) - 1))[n] = \
                b["structure"]["mean_voidage_bed"]
for D in (3, 5, 8, 12, 20):
    cells = [f"| {D} | {benyahia(D):.4f}"]
    for mu in ("0.1", "0.2", "0.3"):
        vals = [v for v in per.get(f"voidage_r{D}_mu{mu}", []) if v is not None]
        if not vals:
            cells.append(" - ")
            continue
        m = np.mean(vals)
        sd = np.std(vals, ddof=1) if len(vals) > 1 else float("nan")
        cells.append(f"{m:.4f} ± {sd:.4f} ({m - benyahia(D):+.3f}; "
                     + " / ".join(f"{x:.4f}" for x in vals) + ")")
    print(" | ".join(cells) + " |")
