"""Shared by the bench/flow shell scripts' summaries: the DEM sphere bed they all pour, and one
run's wall and CPU seconds and load as the scripts record them (/usr/bin/time -f "%e %U" and
/proc/loadavg before | after)."""
import os

DEM_BED = ("voxpack pack --mode dem --shape sphere:d=3 --container cylinder:d=15,h=20 "
           "--count 60 --seed 1")


def run_record(out, tag):
    """wall_s, cpu_s and load_1_5_15 of the run whose files are time_TAG.txt, load_TAG.txt."""
    wall, cpu = open(os.path.join(out, f"time_{tag}.txt")).read().split()[-2:]
    load = open(os.path.join(out, f"load_{tag}.txt")).read().strip()
    return {"wall_s": float(wall), "cpu_s": float(cpu), "load_1_5_15": load}
