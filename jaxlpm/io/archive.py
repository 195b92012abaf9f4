"""`save(result, path)` and `load(path)`: a jaxlpm result in one .npz file, without pickle.

A result is a `Solution` (batched or not, any family), a sweep's or re-planning Monte
Carlo's `SweepResult`, an `execution_monte_carlo` dict, or any nest of these (dicts, lists,
tuples). The file is a zip archive that `numpy.load(path, allow_pickle=False)` also opens:
  metadata.json   schema_version, jaxlpm_version, created (UTC, ISO 8601), kind (the
                  result's class); for a Solution also problem (its class), method, frame,
                  grid ({"scheme", "points"}, a mesh's {"mesh", "segments",
                  "points_per_segment", "breaks"}, an LQR sweep's {"steps"}, or null),
                  status (its name; for a batch {name: members}) and batch_shape; then
                  structure, the result as `jaxlpm.io.tree` encodes it
  aNNNNN.npy      its array leaves, in NumPy's format
`load` gives back the saved object exactly (`jaxlpm.io.tree`): a loaded Solution has the
saved pytree structure and leaves, so states(t), controls(t) and costates(t) are
bit-identical. Units are those of the result itself (SI; states in its `frame`).
"""

import json
import os
import zipfile
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from .._validation import require_x64
from ..collocation import Grid
from ..collocation.segments import Mesh, SegmentedMesh
from ..solution import Solution
from ..status import Status
from .tree import decode, encode

SCHEMA_VERSION = 1
"""The archive layout `save` writes and `load` reads (metadata.json's schema_version)."""
METADATA = "metadata.json"


def _status_name(code: int) -> str:
    try:
        return Status(code).name
    except ValueError:
        return f"UNKNOWN({code})"


def _grid(grid):
    """The grid or mesh in words (JSON)."""
    if isinstance(grid, Grid):
        return {"scheme": grid.scheme, "points": grid.n}
    if isinstance(grid, (Mesh, SegmentedMesh)):
        inner = grid.segment if isinstance(grid, Mesh) else grid.grid
        breaks = np.asarray(grid.breaks)
        return {"mesh": type(grid).__name__, "segments": breaks.shape[-1] - 1,
                "points_per_segment": inner.n,
                "breaks": breaks.tolist() if breaks.ndim == 1 else "per member"}
    if isinstance(grid, int):
        return {"steps": grid}
    return None


def _solution_summary(sol: Solution) -> dict:
    status = np.asarray(sol.status)
    if status.ndim:
        codes, counts = np.unique(status, return_counts=True)
        words = {_status_name(int(c)): int(k) for c, k in zip(codes, counts)}
    else:
        words = _status_name(int(status))
    return {"problem": type(sol.problem).__name__, "method": sol.method, "frame": sol.frame,
            "grid": _grid(sol.grid), "status": words, "batch_shape": list(status.shape)}


def _version() -> str:
    """jaxlpm.__version__, read at call time (the package root imports this module)."""
    import jaxlpm
    return jaxlpm.__version__


def save(result, path) -> Path:
    """Write `result` (module docstring) to `path` (a new or replaced file; ".npz" is the
    convention) and return the path. The file is written under a temporary name and renamed,
    so an interrupted save leaves no partial file. ValueError naming the part of `result`
    that cannot be saved (a traced value, a class from outside jaxlpm, an object array)."""
    path = Path(path)
    structure, arrays = encode(result)
    metadata = {"schema_version": SCHEMA_VERSION, "jaxlpm_version": _version(),
                "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
                "kind": type(result).__name__}
    if isinstance(result, Solution):
        metadata.update(_solution_summary(result))
    metadata["structure"] = structure
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with zipfile.ZipFile(tmp, "w", compression=zipfile.ZIP_DEFLATED) as zf:
            zf.writestr(METADATA, json.dumps(metadata, indent=1, allow_nan=False))
            for name, arr in arrays.items():
                with zf.open(f"{name}.npy", "w", force_zip64=True) as fh:
                    np.lib.format.write_array(fh, arr, allow_pickle=False)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path


def read_metadata(path) -> dict:
    """The metadata.json of a file `save` wrote (module docstring), without its arrays;
    ValueError if `path` is not such a file or has another schema_version."""
    path = Path(path)
    try:
        with zipfile.ZipFile(path) as zf:
            metadata = json.loads(zf.read(METADATA))
    except (zipfile.BadZipFile, KeyError, json.JSONDecodeError) as err:
        raise ValueError(f"{path} is not a jaxlpm archive (a zip with {METADATA}): "
                         f"{type(err).__name__}: {err}") from None
    if metadata.get("schema_version") != SCHEMA_VERSION:
        raise ValueError(f"{path} has schema_version {metadata.get('schema_version')!r}; this "
                         f"jaxlpm reads {SCHEMA_VERSION}")
    return metadata


def load(path):
    """The result `save` wrote to `path`, rebuilt exactly (module docstring). ValueError if
    the file is not a jaxlpm archive, has another schema_version or names a class outside
    jaxlpm; float64 must be enabled."""
    require_x64()
    path = Path(path)
    metadata = read_metadata(path)
    with zipfile.ZipFile(path) as zf:
        arrays = {}
        for member in zf.namelist():
            if member.endswith(".npy"):
                with zf.open(member) as fh:
                    arrays[member[:-4]] = np.lib.format.read_array(fh, allow_pickle=False)
    return decode(metadata["structure"], arrays)
