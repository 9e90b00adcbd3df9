"""Reads every `voxpack export` output back with independent readers (VTK, meshio,
tifffile, h5py, the csv module) and checks it against the bed written here with h5py.

Usage: check_export.py VOXPACK CHECK   (CHECK: xdmf vtkhdf vtk tiff nrrd mha csv stl obj)
Exit 0 when the check holds; an assertion message otherwise.
"""
import csv
import gzip
import math
import os
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET
import zlib

import h5py
import numpy as np

SPACING = (0.25, 0.25, 0.25)  # z, y, x
DIMS = (44, 48, 48)           # nz, ny, nx
ORIGIN = (0.125, -5.875, -5.875)  # centre of voxel [0,0,0], z, y, x
CONTAINER = "cylinder:d=11,h=11"
# Two spheres touching, one touching the wall, a cylinder standing on sphere 1.
PARTICLES = [
    ("sphere:d=3", (0.0, 0.0, 1.5), (1.0, 0.0, 0.0, 0.0)),
    ("sphere:d=3", (3.0, 0.0, 1.5), (1.0, 0.0, 0.0, 0.0)),
    ("sphere:d=3", (0.0, -4.0, 1.5), (1.0, 0.0, 0.0, 0.0)),
    ("cylinder:d=3,l=2", (0.0, 0.0, 4.0), (1.0, 0.0, 0.0, 0.0)),
    ("cylinder:d=2.5,l=3", (-2.0, 2.0, 7.0), (math.cos(0.4), math.sin(0.4), 0.0, 0.0)),
]


def exact_volume(spec):
    name, args = spec.split(":")
    v = {k: float(x) for k, x in (a.split("=") for a in args.split(","))}
    if name == "sphere":
        return math.pi * v["d"] ** 3 / 6
    if name == "cylinder":
        return math.pi * v["d"] ** 2 / 4 * v["l"]
    raise ValueError(spec)


def rotate_inverse(q, p):
    """Body-frame coordinates of world offsets p (N,3) for unit quaternion q (w,x,y,z)."""
    w, x, y, z = q
    R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    return p @ R  # row vectors: p R = (R^T p^T)^T


def inside(spec, centre, q, pts):
    name, args = spec.split(":")
    v = {k: float(x) for k, x in (a.split("=") for a in args.split(","))}
    b = rotate_inverse(q, pts - np.asarray(centre))
    if name == "sphere":
        return (b ** 2).sum(axis=1) <= (v["d"] / 2) ** 2
    return (b[:, 0] ** 2 + b[:, 1] ** 2 <= (v["d"] / 2) ** 2) & (np.abs(b[:, 2]) <= v["l"] / 2)


def centres():
    k, j, i = np.meshgrid(*[np.arange(n) for n in DIMS], indexing="ij")
    z = ORIGIN[0] + k * SPACING[0]
    y = ORIGIN[1] + j * SPACING[1]
    x = ORIGIN[2] + i * SPACING[2]
    return np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)


def voxelise(particles):
    pts = centres()
    labels = np.zeros(len(pts), dtype=np.uint32)
    for n, (spec, c, q) in enumerate(particles):
        labels[inside(spec, c, q, pts) & (labels == 0)] = n + 1
    return labels.reshape(DIMS)


def write_bed(path):
    labels = voxelise(PARTICLES)
    indicator = (labels == 0).astype(np.uint8)
    pts = centres()
    mask = ((pts[:, 0] ** 2 + pts[:, 1] ** 2 <= 5.5 ** 2) & (pts[:, 2] >= 0) & (pts[:, 2] <= 11))
    mask = mask.reshape(DIMS).astype(np.uint8)
    with h5py.File(path, "w") as f:
        f.attrs["format"] = "voxpack-bed"
        f.attrs["format_version"] = 1
        f.attrs["spacing_mm"] = np.asarray(SPACING, dtype=np.float64)
        f.attrs["origin_mm"] = np.asarray(ORIGIN, dtype=np.float64)
        f.attrs["provenance"] = ('{"writer": "h5py by hand", "scene": {"container": "%s"}}'
                                 % CONTAINER)
        f.create_dataset("indicator", data=indicator, chunks=True, compression="gzip")
        f.create_dataset("mask", data=mask, chunks=True, compression="gzip")
        f.create_dataset("labels", data=labels, chunks=True, compression="gzip")
        g = f.create_group("particles")
        g.create_dataset("position_mm", data=np.array([p[1] for p in PARTICLES], dtype=np.float64))
        g.create_dataset("orientation", data=np.array([p[2] for p in PARTICLES], dtype=np.float64))
        g.create_dataset("shape", data=np.array([p[0] for p in PARTICLES], dtype=object),
                         dtype=h5py.string_dtype())
        # A flow field as the flow command might add one: a vector per voxel.
        vel = np.zeros(DIMS + (3,), dtype=np.float32)
        vel[..., 2] = indicator
        f.create_dataset("flow/velocity", data=vel, chunks=True, compression="gzip")
    return indicator, mask, labels


def run(voxpack, *args):
    r = subprocess.run([voxpack, "export", *args, "--quiet"], capture_output=True, text=True)
    assert r.returncode == 0, f"voxpack export {args}: exit {r.returncode}: {r.stderr}"
    return r


NUMBER_TYPES = {("UChar", 1): np.uint8, ("UInt", 4): np.uint32, ("Float", 4): np.float32,
                ("Float", 8): np.float64, ("Char", 1): np.int8, ("Int", 4): np.int32}


def check_xdmf(voxpack, tmp, bed, data):
    out = os.path.join(tmp, "bed.xdmf")
    run(voxpack, bed, "--format", "xdmf", "-o", out)
    root = ET.parse(out).getroot()
    grid = root.find("Domain/Grid")
    topo = grid.find("Topology")
    assert topo.get("TopologyType") == "3DCoRectMesh"
    assert [int(x) for x in topo.get("Dimensions").split()] == [n + 1 for n in DIMS]
    items = {d.get("Name"): [float(x) for x in d.text.split()] for d in grid.find("Geometry")}
    assert np.allclose(items["Spacing"], SPACING)
    assert np.allclose(items["Origin"], np.asarray(ORIGIN) - np.asarray(SPACING) / 2)
    names = set()
    for attr in grid.findall("Attribute"):
        item = attr.find("DataItem")
        fname, dpath = item.text.strip().split(":")
        path = os.path.join(os.path.dirname(out), fname)
        with h5py.File(path, "r") as f:
            assert dpath in f, f"{dpath} missing from {path}"
            ds = f[dpath]
            dims = tuple(int(x) for x in item.get("Dimensions").split())
            assert ds.shape == dims, f"{dpath}: {ds.shape} vs {dims}"
            want = NUMBER_TYPES[(item.get("NumberType"), int(item.get("Precision")))]
            assert ds.dtype == want, f"{dpath}: {ds.dtype} vs {want}"
            assert attr.get("Center") == "Cell"
            assert attr.get("AttributeType") == ("Vector" if len(dims) == 4 else "Scalar")
        names.add(attr.get("Name"))
    assert {"indicator", "mask", "labels", "flow_velocity"} <= names, names


def read_vtkhdf(path):
    import vtk
    r = vtk.vtkHDFReader()
    r.SetFileName(path)
    r.Update()
    return r.GetOutput()


def check_vtkhdf(voxpack, tmp, bed, data):
    from vtk.util.numpy_support import vtk_to_numpy
    indicator, mask, labels = data
    for link in (False, True):
        out = os.path.join(tmp, f"bed_{int(link)}.vtkhdf")
        run(voxpack, bed, "--format", "vtkhdf", "-o", out, *(["--link"] if link else []))
        img = read_vtkhdf(out)
        assert img is not None and img.GetNumberOfPoints() == indicator.size, "vtkHDFReader read nothing"
        assert tuple(img.GetDimensions()) == (DIMS[2], DIMS[1], DIMS[0])
        assert np.allclose(img.GetSpacing(), SPACING[::-1])
        assert np.allclose(img.GetOrigin(), np.asarray(ORIGIN)[::-1])
        cd = img.GetPointData()
        for name, want in (("indicator", indicator), ("mask", mask), ("labels", labels)):
            arr = cd.GetArray(name)
            assert arr is not None, f"no point array {name}"
            got = vtk_to_numpy(arr).reshape(DIMS)  # VTK: x fastest, as C order [z][y][x]
            assert np.array_equal(got, want), f"{name} differs (link={link})"
        vel = vtk_to_numpy(cd.GetArray("flow_velocity"))
        assert vel.shape == (indicator.size, 3)
    assert os.path.getsize(os.path.join(tmp, "bed_1.vtkhdf")) < os.path.getsize(
        os.path.join(tmp, "bed_0.vtkhdf")), "links should be smaller than copies"


def check_vtk(voxpack, tmp, bed, data):
    import vtk
    from vtk.util.numpy_support import vtk_to_numpy
    out = os.path.join(tmp, "particles.vtk")
    run(voxpack, bed, "--format", "vtk", "-o", out)
    r = vtk.vtkPolyDataReader()
    r.SetFileName(out)
    r.Update()
    pd = r.GetOutput()
    n = len(PARTICLES)
    assert pd.GetNumberOfPoints() == n and pd.GetNumberOfVerts() == n
    pts = vtk_to_numpy(pd.GetPoints().GetData())
    assert np.allclose(pts, [p[1] for p in PARTICLES])
    arrays = pd.GetPointData()
    assert list(vtk_to_numpy(arrays.GetArray("id"))) == list(range(1, n + 1))
    q = vtk_to_numpy(arrays.GetArray("orientation"))
    assert np.allclose(q, [p[2] for p in PARTICLES])
    vol = vtk_to_numpy(arrays.GetArray("volume_mm3"))
    assert np.allclose(vol, [exact_volume(p[0]) for p in PARTICLES], rtol=1e-12)
    axis = vtk_to_numpy(arrays.GetArray("axis"))
    assert np.allclose(np.linalg.norm(axis, axis=1), 1)
    specs = pd.GetFieldData().GetAbstractArray("shape_specs")
    table = [specs.GetValue(i) for i in range(specs.GetNumberOfValues())]
    shape = vtk_to_numpy(arrays.GetArray("shape"))
    assert [table[s] for s in shape] == [p[0] for p in PARTICLES], table
    # Coordination from the labels: face-adjacent voxels of different particles.
    labels = data[2]
    pairs = set()
    for ax in range(3):
        a = np.moveaxis(labels, ax, 0)
        u, v = a[:-1].ravel(), a[1:].ravel()
        sel = (u > 0) & (v > 0) & (u != v)
        pairs |= {(min(x, y), max(x, y)) for x, y in zip(u[sel], v[sel])}
    want = [sum(1 for p in pairs if i + 1 in p) for i in range(n)]
    got = list(vtk_to_numpy(arrays.GetArray("coordination")))
    assert got == want, (got, want)
    assert want[0] >= 2, "the fixture has sphere 1 touching sphere 2 and the cylinder"
    # (meshio 5 reads legacy VTK grids only, not POLYDATA: VTK's reader is the check here.)


def check_tiff(voxpack, tmp, bed, data):
    import tifffile
    out = os.path.join(tmp, "stack")
    run(voxpack, bed, "--format", "tiff", "-o", out)
    files = sorted(os.listdir(out))
    assert len(files) == DIMS[0], len(files)
    stack = []
    for name in files:
        with tifffile.TiffFile(os.path.join(out, name)) as t:
            page = t.pages[0]
            stack.append(page.asarray())
            xr = page.tags["XResolution"].value
            yr = page.tags["YResolution"].value
            assert abs(xr[0] / xr[1] - 1 / SPACING[2]) < 1e-6 and abs(yr[0] / yr[1] - 1 / SPACING[1]) < 1e-6
            meta = t.imagej_metadata
            assert meta is not None and meta["unit"] == "mm", meta
            assert abs(float(meta["spacing"]) - SPACING[0]) < 1e-12, meta
            assert page.dtype == np.uint8
    stack = np.asarray(stack)
    assert np.array_equal(stack, data[0] * 255)
    # Again into the same folder: replaced, not refused.
    run(voxpack, bed, "--format", "tiff", "-o", out)


def read_nrrd(path):
    """A minimal NRRD reader (the header is text; gzip or raw data)."""
    raw = open(path, "rb").read()
    head, body = raw.split(b"\n\n", 1)
    fields = {}
    for line in head.decode().splitlines()[1:]:
        if line.startswith("#") or ":" not in line:
            continue
        k, v = line.split(":", 1)
        fields[k.strip()] = v.strip().lstrip("=")
    sizes = [int(x) for x in fields["sizes"].split()]
    if fields.get("encoding") in ("gzip", "gz"):
        body = gzip.decompress(body)
    a = np.frombuffer(body, dtype=np.uint8)[: np.prod(sizes)].reshape(sizes[::-1])
    dirs = [[float(x) for x in d.strip("()").split(",")] for d in fields["space directions"].split()]
    origin = [float(x) for x in fields["space origin"].strip("()").split(",")]
    return a, [np.linalg.norm(d) for d in dirs], origin, fields


def check_nrrd(voxpack, tmp, bed, data):
    out = os.path.join(tmp, "bed.nrrd")
    run(voxpack, bed, "--format", "nrrd", "-o", out)
    a, spacing, origin, fields = read_nrrd(out)
    assert fields["type"] in ("unsigned char", "uchar", "uint8"), fields["type"]
    assert np.array_equal(a, data[0])
    assert np.allclose(spacing, SPACING[::-1])
    assert np.allclose(origin, ORIGIN[::-1])


def check_mha(voxpack, tmp, bed, data):
    import vtk
    from vtk.util.numpy_support import vtk_to_numpy
    out = os.path.join(tmp, "bed.mha")
    run(voxpack, bed, "--format", "mha", "-o", out)
    r = vtk.vtkMetaImageReader()
    r.SetFileName(out)
    r.Update()
    img = r.GetOutput()
    assert tuple(img.GetDimensions()) == DIMS[::-1]
    assert np.allclose(img.GetSpacing(), SPACING[::-1])
    assert np.allclose(img.GetOrigin(), ORIGIN[::-1])
    got = vtk_to_numpy(img.GetPointData().GetScalars()).reshape(DIMS)
    assert np.array_equal(got, data[0])


def check_csv(voxpack, tmp, bed, data):
    out = os.path.join(tmp, "bed.csv")
    run(voxpack, bed, "--format", "csv", "-o", out)
    with open(out, newline="") as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0].keys()) == ["id", "shape", "x_mm", "y_mm", "z_mm", "qw", "qx", "qy", "qz",
                                    "volume_mm3"]
    assert len(rows) == len(PARTICLES)
    parsed = []
    for n, (row, (spec, c, q)) in enumerate(zip(rows, PARTICLES)):
        assert int(row["id"]) == n + 1 and row["shape"] == spec
        pos = tuple(float(row[k]) for k in ("x_mm", "y_mm", "z_mm"))
        quat = tuple(float(row[k]) for k in ("qw", "qx", "qy", "qz"))
        assert pos == tuple(c) and quat == tuple(q), "poses must round-trip exactly"
        assert abs(float(row["volume_mm3"]) - exact_volume(spec)) < 1e-12 * exact_volume(spec)
        parsed.append((row["shape"], pos, quat))
    # The pose table reproduces the bed: re-digitised from the CSV alone, every voxel agrees.
    assert np.array_equal(voxelise(parsed), data[2])


def parse_stl_solids(path):
    solids, name, tris, cur = {}, None, [], []
    for line in open(path):
        w = line.split()
        if not w:
            continue
        if w[0] == "solid":
            name, tris = w[1], []
        elif w[0] == "vertex":
            cur.append(tuple(w[1:4]))  # exact text: shared vertices weld exactly
            if len(cur) == 3:
                tris.append(cur)
                cur = []
        elif w[0] == "endsolid":
            solids[name] = tris
    return solids


def weld(tris):
    index, faces = {}, []
    for t in tris:
        faces.append([index.setdefault(v, len(index)) for v in t])
    pts = np.zeros((len(index), 3))
    for v, i in index.items():
        pts[i] = [float(x) for x in v]
    return pts, np.asarray(faces)


def closed(faces):
    edges = {}
    for f in faces:
        for e in range(3):
            a, b = f[e], f[(e + 1) % 3]
            edges[(a, b)] = edges.get((a, b), 0) + 1
    return all(c == 1 and edges.get((b, a), 0) == 1 for (a, b), c in edges.items())


def volume(pts, faces):
    a, b, c = pts[faces[:, 0]], pts[faces[:, 1]], pts[faces[:, 2]]
    return np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6


def check_stl(voxpack, tmp, bed, data):
    import vtk
    out = os.path.join(tmp, "bed.stl")
    run(voxpack, bed, "--format", "stl", "-o", out)
    solids = parse_stl_solids(out)
    assert len(solids) == len(PARTICLES) + 1 and "wall" in solids, list(solids)
    total = 0
    for n, (spec, c, q) in enumerate(PARTICLES):
        pts, faces = weld(solids[f"particle_{n + 1}"])
        assert closed(faces), f"particle_{n + 1} is not closed"
        v = volume(pts, faces)
        assert abs(v / exact_volume(spec) - 1) < 0.005, (spec, v, exact_volume(spec))
        assert np.allclose(pts.mean(axis=0), c, atol=0.05)
        total += len(faces)
    pts, faces = weld(solids["wall"])
    assert closed(faces)
    assert abs(volume(pts, faces) / (math.pi * 5.5 ** 2 * 11) - 1) < 0.005
    total += len(faces)
    r = vtk.vtkSTLReader()
    r.SetFileName(out)
    r.Update()
    assert r.GetOutput().GetNumberOfCells() == total, (r.GetOutput().GetNumberOfCells(), total)
    # Every contact treatment writes closed solids; bridge and overlap one union solid.
    for treatment in ("gap", "cap", "bridge", "overlap"):
        o = os.path.join(tmp, f"bed_{treatment}.stl")
        run(voxpack, bed, "--format", "stl", "-o", o, "--contacts", treatment)
        s = parse_stl_solids(o)
        want = 2 if treatment in ("bridge", "overlap") else len(PARTICLES) + 1
        assert len(s) == want, (treatment, list(s))
        for name, tris in s.items():
            if name == "bed":
                # The CGAL union is welded before writing (intersection points closer
                # than float resolution merged, collapsed and coincident triangles
                # dropped): read back by position, it is one closed oriented surface, and
                # VTK (float points, merged) finds no open or non-manifold edge.
                pts, faces = weld(tris)
                assert closed(faces), f"{treatment}: the union is not closed by position"
                v = volume(pts, faces)
                total = sum(exact_volume(p[0]) for p in PARTICLES)
                assert total * 0.99 < v < total * 1.06, (treatment, v, total)
                r = vtk.vtkSTLReader()
                r.SetFileName(o)
                r.Update()
                fe = vtk.vtkFeatureEdges()
                fe.SetInputConnection(r.GetOutputPort())
                fe.BoundaryEdgesOn()
                fe.NonManifoldEdgesOn()
                fe.FeatureEdgesOff()
                fe.ManifoldEdgesOff()
                fe.Update()
                assert fe.GetOutput().GetNumberOfCells() == 0, (
                    treatment, fe.GetOutput().GetNumberOfCells(), "open/non-manifold edges")
                continue
            assert closed(weld(tris)[1]), f"{treatment}: {name} is not closed"


def check_obj(voxpack, tmp, bed, data):
    import meshio
    out = os.path.join(tmp, "bed.obj")
    run(voxpack, bed, "--format", "obj", "-o", out)
    m = meshio.read(out)
    tri = sum(len(c.data) for c in m.cells if c.type == "triangle")
    stl = os.path.join(tmp, "bed.stl")
    run(voxpack, bed, "--format", "stl", "-o", stl)
    assert tri == sum(len(t) for t in parse_stl_solids(stl).values())
    objects = [l.split()[1] for l in open(out) if l.startswith("o ")]
    assert objects == [f"particle_{n + 1}" for n in range(len(PARTICLES))] + ["wall"]


def main():
    voxpack, check = sys.argv[1], sys.argv[2]
    with tempfile.TemporaryDirectory() as tmp:
        bed = os.path.join(tmp, "bed.h5")
        data = write_bed(bed)
        globals()["check_" + check](voxpack, tmp, bed, data)
    print(f"{check}: ok")


if __name__ == "__main__":
    main()
