# Opens an XDMF sidecar written by `voxpack export BED.h5 --format xdmf` with ParaView's own
# XDMF reader (Debian `paraview`, offscreen) and checks what a user would see: the grid's
# dims, spacing and origin, and each array's range. Not run by CI (ParaView is not a build
# dependency); CI checks the XML and the datasets with h5py (tests/export/check_export.py).
#   xvfb-run -a pvbatch bench/export/check_xdmf_paraview.py BED.xdmf BED.h5 [OUT.json]
# (Debian: apt-get install paraview python3-paraview xvfb)
import json
import sys

import h5py
import numpy as np
from paraview import simple
from paraview import servermanager as sm

xdmf, bed = sys.argv[1], sys.argv[2]
reader = simple.XDMFReader(FileNames=[xdmf])
reader.UpdatePipeline()
data = sm.Fetch(reader)
with h5py.File(bed, "r") as f:
    ind = f["indicator"][...]
    spacing = f.attrs["spacing_mm"]
    origin = f.attrs["origin_mm"]
    names = [n for n in ("indicator", "mask", "labels") if n in f]
    truth = {n: f[n][...] for n in names}
nz, ny, nx = ind.shape
# Cell data on a grid of (nx+1, ny+1, nz+1) points, or point data on (nx, ny, nz).
dims = data.GetDimensions()
res = {"reader": reader.GetXMLName(), "dims_points": list(dims),
       "spacing": list(data.GetSpacing()), "origin": list(data.GetOrigin()), "arrays": {}}
cells = data.GetCellData()
ok = tuple(dims) in ((nx + 1, ny + 1, nz + 1), (nx, ny, nz))
ok &= np.allclose(data.GetSpacing(), spacing[::-1])
# Cell data: the grid's points are the voxel corners, half a voxel before the first centre.
corner = np.asarray(origin[::-1]) - (0.5 * np.asarray(spacing[::-1]) if tuple(dims) == (nx + 1, ny + 1, nz + 1) else 0)
res["origin_expected"] = corner.tolist()
ok &= np.allclose(data.GetOrigin(), corner)
for n in names:
    arr = cells.GetArray(n) or data.GetPointData().GetArray(n)
    if arr is None:
        res["arrays"][n] = "missing"
        ok = False
        continue
    from vtk.util.numpy_support import vtk_to_numpy
    v = vtk_to_numpy(arr)
    same = v.size == truth[n].size and np.array_equal(v.reshape(truth[n].shape), truth[n])
    res["arrays"][n] = {"range": list(arr.GetRange()), "values_equal_h5": bool(same)}
    ok &= same
res["ok"] = bool(ok)
print(json.dumps(res, indent=1))
if len(sys.argv) > 3:
    json.dump(res, open(sys.argv[3], "w"), indent=1)
sys.exit(0 if ok else 1)
