"""Running the voxpack command line in-process, and the small file helpers it needs
(TOML scenes, NRRD images). Nothing here computes: the C++ commands do."""

from __future__ import annotations

import contextlib
import gzip
import inspect
import json
import logging
import math
import os
import re
import tempfile
from typing import Any, Callable, Mapping, Optional, Sequence

import numpy as np

from . import _voxpack

log = logging.getLogger("voxpack")


def progress_adapter(progress: Optional[Callable]) -> Optional[Callable]:
    """The C++ hook calls f(fraction, stage); the user's callable gets (done, total) with
    total = 1.0 (done is the fraction of the current stage), plus the stage name when it
    takes a third positional argument."""
    if progress is None:
        return None
    if not callable(progress):
        raise ValueError("progress: expected a callable progress(done, total)")
    takes_stage = False
    try:
        params = [p for p in inspect.signature(progress).parameters.values()
                  if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD, p.VAR_POSITIONAL)]
        takes_stage = len(params) >= 3 or any(p.kind == p.VAR_POSITIONAL for p in params)
    except (TypeError, ValueError):
        pass
    if takes_stage:
        return lambda fraction, stage: progress(fraction, 1.0, stage)
    return lambda fraction, stage: progress(fraction, 1.0)


def _message(text: str) -> None:
    if text.startswith("warning"):
        log.warning("%s", text)
    else:
        log.info("%s", text)


def global_args(threads: Optional[int], memory_limit: Optional[str]) -> list:
    """The CLI's global options: always --quiet (messages go to the 'voxpack' logger)."""
    args = ["voxpack", "--quiet"]
    if threads is not None:
        if int(threads) != threads or threads < 0:
            raise ValueError(f"threads: expected an integer >= 0 (0 = all cores), got {threads!r}")
        args += ["--threads", str(int(threads))]
    if memory_limit is not None:
        args += ["--memory-limit", str(memory_limit)]
    return args


def run_cli(args: Sequence[str], progress: Optional[Callable] = None,
            hide: Sequence[str] = (), capture_stdout: bool = False) -> Optional[str]:
    """Runs `voxpack ARGS...` in this process (GIL released). Exit-2 errors raise
    ValueError / OSError with the CLI's message; paths in `hide` (temporary files) are
    replaced by '<temporary>' in messages. capture_stdout: returns what the command wrote
    to std::cout (e.g. `export --json`) instead of letting it reach the process stdout."""
    text = None
    try:
        if capture_stdout:
            code, text = _voxpack.run_cli_capture([str(a) for a in args],
                                                  progress_adapter(progress), _message)
        else:
            code = _voxpack.run_cli([str(a) for a in args], progress_adapter(progress), _message)
    except (ValueError, OSError, RuntimeError) as e:
        msg = str(e)
        if not any(h and h in msg for h in hide):
            raise
        for h in hide:
            if h:
                msg = msg.replace(h, "<temporary>")
        raise type(e)(msg) from None
    if code != 0:
        raise RuntimeError(f"voxpack {' '.join(map(str, args[1:]))}: exit code {code}")
    return text


@contextlib.contextmanager
def scratch(keep: Optional[str] = None):
    """A temporary folder removed afterwards (also on KeyboardInterrupt)."""
    with tempfile.TemporaryDirectory(prefix="voxpack-") as d:
        yield d


def flags(options: Mapping[str, Any], names: Mapping[str, str]) -> list:
    """Keyword options as CLI flags: key -> --key-with-dashes (or names[key]); True -> the
    bare flag, False / None -> omitted, a list -> the flag repeated."""
    out = []
    for key, value in options.items():
        if value is None or value is False:
            continue
        flag = names.get(key, "--" + key.replace("_", "-"))
        if value is True:
            out.append(flag)
        elif isinstance(value, (list, tuple)) and not isinstance(value, str):
            for v in value:
                out += [flag, _scalar(v)]
        else:
            out += [flag, _scalar(value)]
    return out


def _scalar(v) -> str:
    if isinstance(v, (float, np.floating)):
        return repr(float(v))
    if isinstance(v, np.integer):
        return str(int(v))
    return os.fspath(v) if isinstance(v, os.PathLike) else str(v)


# --- TOML (the scene file, docs/scene.md) -------------------------------------------------

_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")


def _toml_key(k: str) -> str:
    return k if _BARE_KEY.match(k) else json.dumps(k)


def _toml_value(v) -> str:
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, (str, os.PathLike)):
        return json.dumps(os.fspath(v))  # JSON string escapes are valid TOML basic strings
    if isinstance(v, Mapping):
        return "{ " + ", ".join(f"{_toml_key(str(k))} = {_toml_value(x)}" for k, x in v.items()) + " }"
    if isinstance(v, (list, tuple, np.ndarray)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise ValueError(f"scene: cannot write a {type(v).__name__} value ({v!r}) to TOML")


def toml_dumps(scene: Mapping[str, Any]) -> str:
    """A scene dict as TOML: top-level keys first, then one [table] per dict value."""
    lines = []
    tables = []
    for k, v in scene.items():
        if isinstance(v, Mapping):
            tables.append((k, v))
        elif v is not None:
            lines.append(f"{_toml_key(str(k))} = {_toml_value(v)}")
    for k, t in tables:
        lines.append(f"\n[{_toml_key(str(k))}]")
        for kk, vv in t.items():
            if vv is not None:
                lines.append(f"{_toml_key(str(kk))} = {_toml_value(vv)}")
    return "\n".join(lines) + "\n"


# --- NRRD (images in and out of ingest / phantom) -------------------------------------------

_NRRD_TYPES = {"uint8": "uchar", "int8": "signed char", "uint16": "ushort", "int16": "short",
               "uint32": "uint", "int32": "int", "float32": "float", "float64": "double"}
_NRRD_DTYPES = {
    "uchar": np.uint8, "unsigned char": np.uint8, "uint8": np.uint8, "uint8_t": np.uint8,
    "signed char": np.int8, "int8": np.int8, "int8_t": np.int8, "char": np.int8,
    "ushort": np.uint16, "unsigned short": np.uint16, "uint16": np.uint16, "uint16_t": np.uint16,
    "short": np.int16, "signed short": np.int16, "int16": np.int16, "int16_t": np.int16,
    "uint": np.uint32, "unsigned int": np.uint32, "uint32": np.uint32, "uint32_t": np.uint32,
    "int": np.int32, "signed int": np.int32, "int32": np.int32, "int32_t": np.int32,
    "float": np.float32, "double": np.float64,
}


def write_nrrd(path: str, image: np.ndarray, spacing_mm, origin_mm) -> None:
    """Writes a 3-D [z][y][x] array as an attached, raw NRRD (axes x, y, z fastest first),
    the way ITK writes one, so `voxpack ingest` reads it with this spacing and origin."""
    a = np.asarray(image)
    if a.dtype == np.bool_:
        a = a.astype(np.uint8)
    if a.dtype.name not in _NRRD_TYPES:
        raise ValueError(f"image: dtype {a.dtype} is not accepted (use an integer or float array)")
    if a.ndim != 3:
        raise ValueError(f"image: expected a 3-D array [z][y][x], got shape {a.shape}")
    a = np.ascontiguousarray(a.astype(a.dtype.newbyteorder("<"), copy=False))
    sz, sy, sx = spacing_mm
    oz, oy, ox = origin_mm
    header = (
        "NRRD0004\n"
        f"type: {_NRRD_TYPES[a.dtype.name]}\n"
        "dimension: 3\n"
        "space: left-posterior-superior\n"
        f"sizes: {a.shape[2]} {a.shape[1]} {a.shape[0]}\n"
        f"space directions: ({sx!r},0,0) (0,{sy!r},0) (0,0,{sz!r})\n"
        "kinds: domain domain domain\n"
        "endian: little\n"
        "encoding: raw\n"
        f"space origin: ({ox!r},{oy!r},{oz!r})\n\n"
    )
    with open(path, "wb") as f:
        f.write(header.encode("ascii"))
        f.write(a.tobytes())


def read_nrrd(path: str):
    """Reads an attached raw or gzip NRRD with axis-aligned space directions (what
    `voxpack phantom` writes). Returns (array [z][y][x], spacing_mm, origin_mm) (z, y, x)."""
    with open(path, "rb") as f:
        data = f.read()
    end = data.find(b"\n\n")
    if not data.startswith(b"NRRD") or end < 0:
        raise OSError(f"{path}: not an attached NRRD file")
    fields = {}
    for line in data[:end].decode("latin-1").splitlines()[1:]:
        if line.startswith("#") or ":" not in line:
            continue
        k, v = line.split(":", 1)
        fields[k.strip()] = v.strip().lstrip("=").strip()
    sizes = [int(s) for s in fields["sizes"].split()]
    if len(sizes) != 3:
        raise ValueError(f"{path}: expected a 3-D image, got sizes {sizes}")
    dtype = np.dtype(_NRRD_DTYPES[fields["type"]])
    if dtype.itemsize > 1 and fields.get("endian", "little") == "big":
        dtype = dtype.newbyteorder(">")
    raw = data[end + 2:]
    encoding = fields.get("encoding", "raw")
    if encoding in ("gzip", "gz"):
        raw = gzip.decompress(raw)
    elif encoding != "raw":
        raise ValueError(f"{path}: NRRD encoding {encoding} is not supported here")
    a = np.frombuffer(raw, dtype=dtype, count=sizes[0] * sizes[1] * sizes[2])
    a = a.reshape(sizes[2], sizes[1], sizes[0]).astype(dtype.newbyteorder("="), copy=False)
    spacing = [1.0, 1.0, 1.0]
    if "space directions" in fields:
        vecs = re.findall(r"\(([^)]*)\)", fields["space directions"])
        spacing = [float(np.linalg.norm([float(x) for x in v.split(",")])) for v in vecs]
    elif "spacings" in fields:
        spacing = [float(s) for s in fields["spacings"].split()]
    origin = [0.0, 0.0, 0.0]
    if "space origin" in fields:
        origin = [float(x) for x in fields["space origin"].strip("()").split(",")]
    return a, tuple(spacing[::-1]), tuple(origin[::-1])
