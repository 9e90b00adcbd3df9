"""Figures of a `voxpack compare` report, drawn from the CSV files and text arrays that
voxpack wrote into the report folder (paper Figs. 4, 6, 7, 8, 9, 10).

Usage: make_figures.py REPORT_DIR OUT_DIR
Exit status 3 when numpy or matplotlib is missing (voxpack then reports without figures).
"""
import csv
import math
import os
import sys

try:
    import numpy as np
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError as exc:  # voxpack turns this into a warning
    sys.stderr.write("matplotlib/numpy not available: %s\n" % exc)
    sys.exit(3)


def read_rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def num(text):
    try:
        return float(text)
    except (TypeError, ValueError):
        return math.nan


def by_bed(rows, x, y, extra=None):
    out = {}
    for r in rows:
        d = out.setdefault(r["bed"], {"x": [], "y": [], "e": []})
        d["x"].append(num(r[x]))
        d["y"].append(num(r[y]))
        d["e"].append(num(r[extra]) if extra else 1.0)
    return {k: {kk: np.asarray(vv) for kk, vv in v.items()} for k, v in out.items()}


def label(bed):
    text = bed["name"]
    if bed["role"] == "reference":
        text += " (reference"
        text += ", synthetic)" if bed["synthetic"] == "1" else ")"
    elif bed["synthetic"] == "1" and bed["kind"] != "simulated":
        text += " (synthetic)"
    return text


def save(fig, out_dir, name):
    # Write under a temporary name and rename, so no half-written PNG is left behind.
    final = os.path.join(out_dir, name)
    tmp = final + ".part.png"
    fig.savefig(tmp, dpi=110)
    plt.close(fig)
    os.replace(tmp, final)


def line_style(bed):
    return dict(color="black", linewidth=2.0) if bed["role"] == "reference" else dict(linewidth=1.3)


def fig_axial(beds, rep, out):
    data = by_bed(read_rows(os.path.join(rep, "axial.csv")), "z_mm", "density", "used")
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4.2), gridspec_kw={"width_ratios": [3, 2]})
    for bed in beds:
        d = data.get(bed["name"])
        if d is None or d["x"].size == 0:
            continue
        (ln,) = ax1.plot(d["x"], d["y"], label=label(bed), **line_style(bed))
        kept = d["x"][d["e"] > 0.5]
        if bed["role"] == "reference" and kept.size:
            # Slices outside the shaded band are the trimmed bed ends (not in m, s or KS).
            ax1.axvspan(kept.min(), kept.max(), color="0.9", zorder=0)
        used = d["y"][(d["e"] > 0.5) & np.isfinite(d["y"])]
        if used.size == 0:
            continue
        ax2.hist(used, bins=max(5, min(30, used.size // 4)), density=True, alpha=0.35,
                 color=ln.get_color())
        m = float(np.mean(used))
        s = float(np.std(used, ddof=1)) if used.size > 1 else 0.0  # as stats' axial.std
        if s > 0:
            x = np.linspace(m - 4 * s, m + 4 * s, 200)
            ax2.plot(x, np.exp(-0.5 * ((x - m) / s) ** 2) / (s * math.sqrt(2 * math.pi)),
                     color=ln.get_color(), label="m=%.3f, s=%.3f" % (m, s))
    ax1.set_xlabel("height z (mm)")
    ax1.set_ylabel("slice packing density")
    ax1.set_title("Axial packing density (cf. paper Fig. 4)")
    ax1.legend(fontsize=8)
    ax2.set_xlabel("slice packing density")
    ax2.set_ylabel("probability density")
    ax2.set_title("Distribution of slice densities + normal fit")
    ax2.legend(fontsize=8)
    fig.tight_layout()
    save(fig, out, "fig_axial.png")


def fig_curves(beds, rep, out, csv_name, x, y, xlabel, ylabel, title, png):
    data = by_bed(read_rows(os.path.join(rep, csv_name)), x, y)
    fig, ax = plt.subplots(figsize=(7, 4.2))
    for bed in beds:
        d = data.get(bed["name"])
        if d is None or d["x"].size == 0:
            continue
        order = np.argsort(d["x"])
        ax.plot(d["x"][order], d["y"][order], label=label(bed), **line_style(bed))
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    save(fig, out, png)


def load_image(rep, fname):
    with open(os.path.join(rep, fname)) as f:
        head = f.readline().lstrip("#").split()
    meta = dict(item.split("=", 1) for item in head if "=" in item)
    arr = np.loadtxt(os.path.join(rep, fname), ndmin=2)
    extent = [float(meta["col_from_mm"]), float(meta["col_to_mm"]),
              float(meta["row_from_mm"]), float(meta["row_to_mm"])]
    return arr, extent, meta


def fig_images(beds, rep, out, column, cmap_name, vmin, vmax, title, png, rowlabel):
    images = [load_image(rep, bed[column]) for bed in beds]
    # Panel height follows the data's aspect ratio so that no space is wasted.
    ratios = [abs(e[3] - e[2]) / max(abs(e[1] - e[0]), 1e-9) for _, e, _ in images]
    panel_w = 3.6
    fig_h = min(12.0, max(2.5, panel_w * max(ratios) + 1.3))
    fig, axes = plt.subplots(1, len(beds), figsize=(panel_w * len(beds) + 1.2, fig_h),
                             squeeze=False, layout="constrained")
    cmap = matplotlib.colormaps[cmap_name].copy()
    cmap.set_bad("#d8d8e8")
    im = None
    for n, (ax, bed, (arr, ext, meta)) in enumerate(zip(axes[0], beds, images)):
        im = ax.imshow(np.ma.masked_invalid(arr), origin="lower", extent=ext, cmap=cmap,
                       vmin=vmin, vmax=vmax, interpolation="nearest", aspect="equal")
        ax.set_title(label(bed), fontsize=9)
        ax.set_xlabel("x (mm)")
        if n == 0:
            ax.set_ylabel(rowlabel)
    fig.suptitle(title)
    if im is not None:
        fig.colorbar(im, ax=list(axes[0]), shrink=0.8)
    save(fig, out, png)


def main():
    if len(sys.argv) != 3:
        sys.stderr.write(__doc__)
        return 2
    rep, out = sys.argv[1], sys.argv[2]
    beds = read_rows(os.path.join(rep, "beds.csv"))
    fig_axial(beds, rep, out)
    fig_curves(beds, rep, out, "radial.csv", "wall_distance_mm", "density",
               "distance from the wall (mm)", "annular packing density",
               "Radial packing density (cf. paper Fig. 6)", "fig_radial.png")
    fig_images(beds, rep, out, "shadow_file", "gray_r", 0.0, 1.0,
               "Shadow images: mean solid fraction along y (cf. paper Fig. 7)", "fig_shadow.png",
               "z (mm)")
    fig_images(beds, rep, out, "slice_file", "gray", 0.0, 1.0,
               "Horizontal slice of the void structure, white = void (cf. paper Fig. 8)",
               "fig_slice.png", "y (mm)")
    fig_curves(beds, rep, out, "s2.csv", "h_mm", "s2", "lag h (mm)", "S2(h)",
               "Void two-point probability (cf. paper Fig. 9)", "fig_s2.png")
    fig_curves(beds, rep, out, "mes.csv", "bin_mm", "pdf", "mean empty space (mm)",
               "probability density (1/mm)",
               "Mean-empty-space distribution (cf. paper Fig. 10)", "fig_mes.png")
    if os.path.exists(os.path.join(rep, "flow.csv")):  # compare --flow
        fig_curves(beds, rep, out, "flow.csv", "wall_distance_mm",
                   "axial_velocity_over_superficial", "distance from the wall (mm)",
                   "axial velocity / superficial velocity",
                   "Radial profile of the axial velocity (wall channelling)", "fig_flow.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
