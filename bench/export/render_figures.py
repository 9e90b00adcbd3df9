#!/usr/bin/python3
"""Renders docs/figures/export_contacts.png (one contact before and after each treatment)
and docs/figures/export_cfd_bed.png (the CFD benchmark's bridge export).

    render_figures.py VOXPACK OUT_DIR [CFD_STL]

The contact figure exports a two-sphere bed (spheres d 3 mm touching at one point, written
here with h5py) with every --contacts treatment and draws the triangles near the contact
and draws the STL's cross-section by the plane through both centres (matplotlib, Agg),
so the pictures are the exported triangles themselves.
"""
import os
import subprocess
import sys
import tempfile

import h5py
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402


def read_stl(path):
    tris, cur = [], []
    for line in open(path):
        w = line.split()
        if w and w[0] == "vertex":
            cur.append([float(x) for x in w[1:4]])
            if len(cur) == 3:
                tris.append(cur)
                cur = []
    return np.asarray(tris)


def two_sphere_bed(path):
    dims, h = (24, 24, 40), 0.25
    with h5py.File(path, "w") as f:
        f.attrs["format"] = "voxpack-bed"
        f.attrs["format_version"] = 1
        f.attrs["spacing_mm"] = np.array([h, h, h])
        f.attrs["origin_mm"] = np.array([-2.875, -2.875, -4.875])
        f.attrs["provenance"] = '{"writer": "render_figures.py"}'
        f.create_dataset("indicator", data=np.ones(dims, np.uint8))
        g = f.create_group("particles")
        g.create_dataset("position_mm", data=np.array([[-1.5, 0, 0], [1.5, 0, 0]], float))
        g.create_dataset("orientation", data=np.array([[1.0, 0, 0, 0]] * 2))
        g.create_dataset("shape", data=np.array(["sphere:d=3"] * 2, dtype=object),
                         dtype=h5py.string_dtype())


def section(tris, axis=1, at=1e-4):
    """Segments where the plane x[axis] = at cuts the triangles (the STL's cross-section)."""
    segs = []
    d = tris[:, :, axis] - at
    for t, s in zip(tris, d):
        pts = []
        for a, b in ((0, 1), (1, 2), (2, 0)):
            if (s[a] < 0) != (s[b] < 0):
                w = s[a] / (s[a] - s[b])
                pts.append(t[a] + w * (t[b] - t[a]))
        if len(pts) == 2:
            segs.append([(pts[0][0], pts[0][2]), (pts[1][0], pts[1][2])])
    return segs


def draw(ax, tris, title, box=0.9):
    from matplotlib.collections import LineCollection
    ax.add_collection(LineCollection(section(tris), colors="k", linewidths=1.2))
    ax.set_xlim(-box, box)
    ax.set_ylim(-box, box)
    ax.set_aspect("equal")
    ax.set_xticks([-0.5, 0, 0.5])
    ax.set_yticks([-0.5, 0, 0.5])
    ax.tick_params(labelsize=7)
    ax.grid(alpha=0.3)
    ax.set_title(title, fontsize=9)


def main():
    voxpack, outdir = sys.argv[1], sys.argv[2]
    os.makedirs(outdir, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        bed = os.path.join(tmp, "two.h5")
        two_sphere_bed(bed)
        cases = [("none", [], "none: touch at a point"),
                 ("gap", ["--contact-size", "0.02"], "gap 0.02 d: shrunk"),
                 ("overlap", ["--contact-size", "0.02"], "overlap 0.02 d: grown, one solid"),
                 ("bridge", ["--contact-size", "0.2"], "bridge 0.2 d: cylinder, one solid"),
                 ("cap", ["--contact-size", "0.2"], "cap 0.2 d: flattened")]
        fig = plt.figure(figsize=(12.5, 3.0), dpi=110)
        for n, (t, extra, title) in enumerate(cases):
            out = os.path.join(tmp, f"{t}.stl")
            subprocess.run([voxpack, "export", bed, "--format", "stl", "--contacts", t, *extra,
                            "--contact-tolerance-mm", "0.01", "--tolerance-mm", "0.004", "-o",
                            out, "--quiet"], check=True)
            ax = fig.add_subplot(1, len(cases), n + 1)
            draw(ax, read_stl(out), title)
            if n == 0:
                ax.set_ylabel("z (mm)", fontsize=8)
            ax.set_xlabel("x (mm)", fontsize=8)
        fig.suptitle("Two spheres d = 3 mm touching at the origin: the exported STL cut by the "
                     "plane y = 0 through the contact, before (none) and after each treatment",
                     fontsize=9)
        fig.subplots_adjust(left=0.05, right=0.99, bottom=0.15, top=0.82, wspace=0.25)
        fig.savefig(os.path.join(outdir, "export_contacts.png"))
        plt.close(fig)
    if len(sys.argv) > 3:
        tris = read_stl(sys.argv[3])
        fig = plt.figure(figsize=(5, 6), dpi=120)
        ax = fig.add_subplot(111, projection="3d")
        c = tris.mean(axis=1)
        t = tris[c[:, 1] < 0.5]  # front half cut away to show the bridges inside
        n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
        n /= np.linalg.norm(n, axis=1, keepdims=True) + 1e-30
        light = np.clip(n @ np.array([0.2, -0.8, 0.5]) / np.linalg.norm([0.2, -0.8, 0.5]), 0, 1)
        ax.add_collection3d(Poly3DCollection(t, facecolors=plt.cm.copper(0.2 + 0.75 * light),
                                             linewidths=0))
        ax.set_xlim(-5, 5)
        ax.set_ylim(-5, 5)
        ax.set_zlim(0, 13)
        ax.set_box_aspect((10, 10, 13))
        ax.view_init(elev=12, azim=-90)
        ax.set_axis_off()
        ax.set_title("CFD benchmark bed: 30 spheres d 3 mm, D 10 mm,\nbridge 0.2 d "
                     "(half y < 0.5 mm shown)", fontsize=9)
        fig.savefig(os.path.join(outdir, "export_cfd_bed.png"))
        plt.close(fig)


if __name__ == "__main__":
    main()
