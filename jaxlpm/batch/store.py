"""A sweep's results directory (`ChunkStore`): the manifest and one .npz per finished chunk,
written atomically, checked against their SHA-256 on every reopening; the atomic writers
(`save_npz_atomic`, `write_json_atomic`) shared with the experiments scripts.

On disk, under `out`:
    manifest.json          schema_version, the sweep's `definition`, `runs` (one entry per
                           invocation), `compiles`, `chunks` ({"<group>/<name>": compute log
                           and the file's sha256}) and, once complete, `summary`
    <group>/<name>.npz     one finished chunk, with its compute log (`compute_log`)
Files are written to a temporary name and renamed, so a killed run loses at most the chunk in
flight; a chunk file that is missing, unreadable (truncated, empty) or differs from its logged
SHA-256 is removed and computed again by the rerun (with a warning).
"""

import hashlib
import io
import json
import os
import warnings
import zipfile
from pathlib import Path

import numpy as np

SCHEMA_VERSION = 2       # 2: grid sizes are point counts ("points"; 1 had the degree "N")
MANIFEST = "manifest.json"


def save_npz_atomic(path: Path, **arrays) -> str:
    """np.savez to a temporary name in the same folder, flushed to disk, then renamed; returns
    the SHA-256 (hex) of the file's bytes."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    data = buf.getvalue()
    with open(tmp, "wb") as fh:
        fh.write(data)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)
    return hashlib.sha256(data).hexdigest()


def read_chunk(path: Path, sha256: str | None = None) -> tuple[dict, str]:
    """A chunk file's arrays (compute_log included) and the SHA-256 of its bytes; ValueError
    naming the file if they differ from `sha256` (when given) or it is not a readable chunk
    (empty, truncated, not an .npz, no compute_log)."""
    data = Path(path).read_bytes()
    digest = hashlib.sha256(data).hexdigest()
    if sha256 is not None and digest != sha256:
        raise ValueError(f"sweep chunk {path} is corrupt: its SHA-256 {digest} differs from the "
                         f"manifest's {sha256}")
    try:
        with np.load(io.BytesIO(data)) as z:
            arrays = {k: z[k] for k in z.files}
    except (OSError, EOFError, ValueError, zipfile.BadZipFile) as err:
        raise ValueError(f"sweep chunk {path} is corrupt ({len(data)} bytes): "
                         f"{type(err).__name__}: {err}") from None
    if "compute_log" not in arrays:
        raise ValueError(f"sweep chunk {path} is corrupt: it has no compute_log")
    return arrays, digest


def _json_default(x):
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, Path):
        return str(x)
    raise TypeError(f"not JSON serialisable: {type(x)}")


def write_json_atomic(path: Path, obj) -> None:
    """JSON (indented; NumPy values converted) to a temporary name, then renamed."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(json.dumps(obj, indent=2, default=_json_default) + "\n")
    os.replace(tmp, path)


def _canonical(obj):
    return json.loads(json.dumps(obj, default=_json_default))


class ChunkStore:
    """A results directory of finished chunks: `out/manifest.json` plus one .npz per chunk
    under `out/<group>/`. Opening it creates the manifest or checks that the existing one has
    the same `definition` (ValueError naming the differences otherwise), starts a new run
    entry and checks the chunk files against the log (`_reconcile`); `write` stores a chunk
    atomically and logs it, with its SHA-256, under its key "<group>/<name>"."""

    def __init__(self, out, definition: dict, run_info: dict | None = None):
        self.out = Path(out)
        self.definition = _canonical(definition)
        path = self.out / MANIFEST
        if path.exists():
            m = json.loads(path.read_text())
            if m.get("schema_version") != SCHEMA_VERSION:
                raise ValueError(f"{path} has schema_version {m.get('schema_version')}, this "
                                 f"jaxlpm writes {SCHEMA_VERSION}: use another directory")
            diff = sorted(k for k in set(m["definition"]) | set(self.definition)
                          if m["definition"].get(k) != self.definition.get(k))
            if diff:
                raise ValueError(
                    f"{self.out} holds a different sweep (its definition differs in {diff}): "
                    f"re-run the original command to resume it, or choose another directory. "
                    + "; ".join(f"{k}: stored {m['definition'].get(k)!r:.200}, "
                                f"now {self.definition.get(k)!r:.200}" for k in diff))
        elif self.out.exists() and any(self.out.iterdir()):
            raise ValueError(f"{self.out} exists and is not a sweep directory (no {MANIFEST}): "
                             f"choose an empty or new directory")
        else:
            self.out.mkdir(parents=True, exist_ok=True)
            m = dict(schema_version=SCHEMA_VERSION, definition=self.definition, runs=[],
                     compiles=[], chunks={})
        self.manifest = m
        self.run = len(m["runs"])
        m["runs"].append(_canonical(dict(run=self.run, **(run_info or {}))))
        self._reconcile()
        self._save()

    def _reconcile(self):
        """Make the log and the chunk files agree: remove stale temporary files; unlog (with a
        warning) a logged chunk whose file is missing; remove and unlog (with a warning) a
        file that differs from its logged SHA-256 or, unlogged or logged before checksums,
        cannot be read; log (with its SHA-256) a good file that reached the disk but not the
        manifest (a kill between the two writes) from the compute log it carries. What is
        unlogged is computed again."""
        for tmp in self.out.glob("**/.*.tmp"):
            tmp.unlink()
        chunks = self.manifest["chunks"]
        on_disk = {f"{f.parent.name}/{f.stem}" for f in self.out.glob("*/*.npz")}
        for key in sorted(set(chunks) | on_disk):
            f = self.out / f"{key}.npz"
            log = chunks.pop(key, None)
            if key not in on_disk:
                warnings.warn(f"sweep chunk {f} is in the manifest but missing: computing it again")
                continue
            try:
                arrays, sha256 = read_chunk(f, (log or {}).get("sha256"))
            except ValueError as err:
                warnings.warn(f"{err}; removed, computing it again")
                f.unlink()
                continue
            chunks[key] = dict(log or json.loads(str(arrays["compute_log"])), sha256=sha256)

    def _save(self):
        write_json_atomic(self.out / MANIFEST, self.manifest)

    def path(self, group: str, name: str) -> Path:
        return self.out / group / f"{name}.npz"

    def done(self, group: str, name: str) -> bool:
        return self.path(group, name).exists()

    def write(self, group: str, name: str, arrays: dict, log: dict) -> None:
        log = _canonical(dict(run=self.run, **log))
        self.path(group, name).parent.mkdir(exist_ok=True)
        sha256 = save_npz_atomic(self.path(group, name), compute_log=np.array(json.dumps(log)),
                                 **arrays)
        self.manifest["chunks"][f"{group}/{name}"] = dict(log, sha256=sha256)
        self._save()

    def update(self, **entries) -> None:
        """Set or append top-level manifest entries (lists are appended to) and save."""
        for k, v in _canonical(entries).items():
            if isinstance(self.manifest.get(k), list):
                self.manifest[k].append(v)
            else:
                self.manifest[k] = v
        self._save()
