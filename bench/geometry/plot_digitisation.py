#!/usr/bin/python3
"""Paper Fig. 2 for voxpack: sphere volume and voxel-face surface error vs diameter.

Usage: /usr/bin/python3 bench/geometry/plot_digitisation.py DIR
reads DIR/digitisation_sphere.csv (written by digitisation_sweep DIR) and writes
DIR/digitisation_sphere.png.
"""
import csv
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main() -> None:
    out = Path(sys.argv[1] if len(sys.argv) > 1 else "docs/figures")
    rows = list(csv.DictReader(open(out / "digitisation_sphere.csv")))
    d = [float(r["diameter_voxels"]) for r in rows]
    col = lambda k: [100 * float(r[k]) for r in rows]  # noqa: E731
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    ax[0].plot(d, col("volume_err_centred"), "o-", label="centred on a voxel centre")
    ax[0].errorbar(d, col("volume_err_mean"), yerr=col("volume_err_sd"), fmt="s--", capsize=3,
                   label="20 random sub-voxel centres (mean ± sd)")
    ax[0].axhline(0, color="k", lw=0.5)
    ax[0].set_xlabel("sphere diameter (voxels)")
    ax[0].set_ylabel("volume error (digital − exact)/exact (%)")
    ax[0].set_title("Volume")
    ax[0].legend(fontsize=8)
    ax[1].plot(d, col("surface_err_centred"), "o-", label="centred on a voxel centre")
    ax[1].errorbar(d, col("surface_err_mean"), yerr=col("surface_err_sd"), fmt="s--", capsize=3,
                   label="20 random sub-voxel centres (mean ± sd)")
    ax[1].axhline(50, color="k", lw=0.5, ls=":", label="asymptote 50 %")
    ax[1].set_xlabel("sphere diameter (voxels)")
    ax[1].set_ylabel("voxel-face surface error (%)")
    ax[1].set_title("Surface (voxel faces)")
    ax[1].legend(fontsize=8)
    fig.suptitle("Digitisation error of a sphere (cf. paper Fig. 2)")
    fig.tight_layout()
    fig.savefig(out / "digitisation_sphere.png", dpi=110)
    print(f"wrote {out / 'digitisation_sphere.png'}")


if __name__ == "__main__":
    main()
