#!/usr/bin/python3
"""Collects the CFD benchmark's numbers into one JSON (bench/cfd/run_cfd.sh).

    summarize.py CASE FLOW_JSON EXPORT_JSON OUT_JSON --radius-mm R --bed-height-mm H
                 --nu-mm2-s NU [--timings FILE] [--level L]

OpenFOAM (case in mm): Delta p_kin = <p>(z=0) - <p>(z=H), the area averages on the cutting
planes at the column's faces; the superficial velocity u_s = Q / (pi R^2) with Q the flux
through the inlet patch; k_cfd = nu u_s H / Delta p_kin (Darcy over the column segment).
voxpack flow: k over the same column segment (its sample is the mask's z range, fluid
reservoirs beyond), so both are the apparent permeability of the same tube segment.
"""
import argparse
import json
import math
import os
import re


def last_value(path):
    rows = [l.split() for l in open(path) if l.strip() and not l.startswith("#")]
    return int(float(rows[-1][0])), float(rows[-1][1]), rows


def checkmesh(path):
    text = open(path).read()
    out = {"mesh_ok": "Mesh OK." in text}
    for key, pat in [("cells", r"cells:\s+(\d+)"), ("points", r"points:\s+(\d+)"),
                     ("max_non_orthogonality", r"Mesh non-orthogonality Max:\s+(\d[\d.eE+-]*\d)"),
                     ("max_skewness", r"Max skewness = (\d[\d.eE+-]*\d)"),
                     ("max_aspect_ratio", r"Max aspect ratio = (\d[\d.eE+-]*\d)"),
                     ("fluid_volume_mm3", r"Total volume = (\d[\d.eE+-]*\d)")]:
        m = re.search(pat, text)
        if m:
            out[key] = float(m.group(1)) if "." in m.group(1) or "e" in m.group(1) else int(m.group(1))
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("case")
    ap.add_argument("flow_json")
    ap.add_argument("export_json")
    ap.add_argument("out_json")
    ap.add_argument("--radius-mm", type=float, required=True)
    ap.add_argument("--bed-height-mm", type=float, required=True)
    ap.add_argument("--nu-mm2-s", type=float, required=True)
    ap.add_argument("--timings")
    ap.add_argument("--level", type=int)
    a = ap.parse_args()
    pp = os.path.join(a.case, "postProcessing")
    it, p0, hist0 = last_value(os.path.join(pp, "planeBottom/0/surfaceFieldValue.dat"))
    _, p1, hist1 = last_value(os.path.join(pp, "planeTop/0/surfaceFieldValue.dat"))
    _, qin, _ = last_value(os.path.join(pp, "inletFlux/0/surfaceFieldValue.dat"))
    _, qout, _ = last_value(os.path.join(pp, "outletFlux/0/surfaceFieldValue.dat"))
    dp = p0 - p1
    area = math.pi * a.radius_mm ** 2
    us = -qin / area
    k_cfd = a.nu_mm2_s * us * a.bed_height_mm / dp
    # Convergence: relative change of Delta p over the last 50 iterations written.
    prev = None
    for r0, r1 in zip(hist0, hist1):
        if int(float(r0[0])) <= it - 50:
            prev = float(r0[1]) - float(r1[1])
    flow = json.load(open(a.flow_json))
    exp = json.load(open(a.export_json))
    k_lbm = flow["permeability_mm2"]
    res = {
        "what": "OpenFOAM v1912 simpleFoam (creeping flow) on the snappyHexMesh of a voxpack "
                "bridge export vs voxpack flow (LB) on the same bed",
        "bed": {"particles": exp.get("particles"), "shape": "sphere:d=3",
                "container": exp.get("container"), "contacts": exp.get("contacts"),
                "contact_size_d": exp.get("contact_size_d"),
                "particle_contacts": exp.get("particle_contacts"),
                "wall_contacts": exp.get("wall_contacts"),
                "stl_triangles": exp.get("triangles"), "stl_bytes": exp.get("bytes"),
                "stl_closed_manifold": exp.get("closed_manifold"),
                "stl_self_intersecting": exp.get("self_intersecting")},
        "openfoam": {
            "surface_level": a.level,
            **checkmesh(os.path.join(a.case, "log.checkMesh")),
            "iterations": it,
            "p_kin_bottom_mm2_s2": p0, "p_kin_top_mm2_s2": p1,
            "delta_p_kin_mm2_s2": dp,
            "delta_p_rel_change_last_50_iterations": (abs(dp - prev) / dp) if prev else None,
            "inlet_flux_mm3_s": -qin, "outlet_flux_mm3_s": qout,
            "superficial_velocity_mm_s": us,
            "nu_mm2_s": a.nu_mm2_s,
            "reynolds_particle": us * 3.0 / a.nu_mm2_s,
            "permeability_mm2": k_cfd,
            "pressure_gradient_pa_m_at_1mm_s_water": 1e-3 * 1e-3 / (k_cfd * 1e-6),
        },
        "voxpack_flow": {
            "permeability_mm2": k_lbm, "status": flow.get("status"), "steps": flow.get("steps"),
            "porosity": flow.get("porosity"),
            "reynolds": flow.get("reynolds"), "wall_s": flow.get("wall_s"),
            "pressure_gradient_pa_m_at_1mm_s_water": flow["pressure_gradient"]["darcy_pa_m"],
            "correlations_mm2": flow.get("permeability_correlations"),
        },
        "difference": {
            "k_cfd_over_k_lbm": k_cfd / k_lbm,
            "relative_difference_k": (k_cfd - k_lbm) / k_lbm,
            "delta_p_lbm_over_delta_p_cfd": k_cfd / k_lbm,
        },
    }
    if a.timings and os.path.exists(a.timings):
        res["timings"] = [l.rstrip("\n") for l in open(a.timings)]
    json.dump(res, open(a.out_json, "w"), indent=2)
    print(json.dumps(res["difference"], indent=2))
    print("k_cfd %.5g mm2, k_lbm %.5g mm2" % (k_cfd, k_lbm))


if __name__ == "__main__":
    main()
