"""Parameter sweeps: one compiled function per grid size, fixed-shape chunks sharded across
every device (of every process), each finished chunk written to disk as it goes, resumable.

A sweep solves a `Family` (how to build one problem from one member's parameters, how to solve
it on a grid) for every member of a parameter table (a dict of arrays with a common leading
axis, e.g. from `parameter_grid`) at every N of a list of grid sizes:

    for each N (ascending): grid = family.grid(N); one function
        jit(shard_map(lax.map(solve(build(member), grid), batch_size)))
    compiled ahead of time once, for one chunk shape: members are taken `chunk_size` at a time
    in order, the last chunk padded with copies of its first member (so nothing recompiles);
    a chunk of devices x per_device rows is placed on P("batch") of the mesh
    jax.make_mesh((devices,), ("batch",), AxisType.Auto), each device solving its own block
    (no communication); lax.map with `batch_size` bounds the members a device holds in flight.

On disk (`ChunkStore`), under `out`:
    manifest.json          schema_version, the sweep's `definition` (family, its settings, the
                           Ns, chunk size, parameter names, shapes and SHA-256), `runs` (one
                           entry per invocation), `compiles` (seconds per N and run), `chunks`
                           ({"N16/chunk_00003": compute log: run, seconds, devices, members,
                           converged, finished, and the file's sha256}) and, once complete,
                           `summary` (per N: members, converged, the non-converged member
                           indices).
    N<N>/chunk_XXXXX.npz   one finished chunk: index (member numbers), N, the members'
                           parameters and the solver's outputs, one row per member;
                           `pandas.DataFrame({k: v for k, v in np.load(f).items() if v.ndim == 1})`.
Files are written to a temporary name and renamed (atomic), so a killed run loses at most the
chunk in flight; re-running the same sweep skips the chunks on disk, and a directory made by a
different definition is refused with a ValueError naming what differs. A chunk file that is
missing, unreadable (truncated, empty) or differs from its logged SHA-256 is removed and
computed again by the rerun (with a warning); `load_sweep` refuses it with a ValueError naming
the file.

The persistent compilation cache is the caller's to configure (the `jaxlpm sweep` CLI does);
with it a rerun skips compilation too.
"""

import hashlib
import io
import json
import os
import platform
import sys
import time
import warnings
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import jax
import jax.numpy as jnp
import numpy as np
from jax.experimental import multihost_utils
from jax.sharding import NamedSharding, PartitionSpec as P
from tqdm import tqdm

from .._validation import require_x64
from ..collocation import lgl
from ..problems import EnergyOptimalTransfer
from ..problems.energy_optimal import perigee_above_surface
from ..solvers import solve
from ..status import Status

SCHEMA_VERSION = 1
MANIFEST = "manifest.json"
PERCENTILES = (5.0, 50.0, 95.0)       # reported by default with the mean and spread


# ------------------------------------------------------------------------------------------
# problem families


@dataclass(frozen=True)
class Family:
    """A problem family for `sweep`.

    name        short name, recorded in the manifest
    build       (member parameters: dict of arrays, one member's slice) -> problem pytree;
                traced (under vmap/lax.map), so jnp only
    solve       (problem, grid) -> dict of arrays, one member's record, with an integer
                "status" (`Status`; 0 = converged); traced
    grid        N -> `Grid` (the family's node-count convention)
    definition  JSON-able settings that determine the results (what is held fixed, method,
                options, conventions); two sweeps with different definitions never share a
                directory
    min_N       smallest N the family accepts
    validate    optional host check of the parameter table (ValueError on bad input)
    cpu_batch_size  the vmap width `sweep` uses on the CPU backend when the caller gives none
                (None: all of a device's members of the chunk). 1 for solvers built on LAPACK
                factorisations: on CPU a vmapped LAPACK call runs member by member anyway,
                and jaxlib 0.10's batched kernels deadlock when two devices run them at once
                (the KKT law's sweep on 2 CPU devices hung at N = 64; experiments/README.md)
    """

    name: str
    build: Callable
    solve: Callable
    grid: Callable
    definition: dict = field(default_factory=dict)
    min_N: int = 1
    validate: Callable | None = None
    cpu_batch_size: int | None = None


TRANSFER_PARAMETERS = ("e", "a", "i", "raan", "argp", "f0", "revolutions", "duration", "x0",
                       "xf")
HOLDS = ("perigee", "a")
TRANSFER_METHODS = {"kkt": "linear", "stm": "linear", "newton": "two-body"}


def map_in_groups(fun, xs, width):
    """`lax.map` of fun over xs' leading axis in vmapped groups of `width` members; width 1
    (or None) runs the members one at a time, not vmapped: a vmap, even of one member, turns
    every `lax.cond` of an iterative solver into a select that runs both branches."""
    return jax.lax.map(fun, xs, batch_size=None if width in (None, 1) else width)


def transfer_builder(base: EnergyOptimalTransfer, hold: str = "perigee") -> Callable:
    """Build an `EnergyOptimalTransfer` from `base` with a member's parameters replacing its
    leaves: orbit elements (e, a, i, raan, argp, f0; SI, rad), the duration as `revolutions`
    (chief periods of the member's orbit) or `duration` (s), and x0, xf (LVLH, m, m/s).

    A member with e but no a holds the chief's perigee radius r_p = a (1 - e) of `base`
    (hold="perigee": a = r_p / (1 - e)) or its semi-major axis (hold="a"). A member with
    neither revolutions nor duration keeps `base`'s duration in revolutions.
    """
    if hold not in HOLDS:
        raise ValueError(f"hold must be one of {HOLDS}, got {hold!r}")
    o = base.orbit
    r_p = o.a * (1.0 - o.e)
    revolutions = base.duration / o.period

    def build(p):
        elements = {k: p[k] for k in ("e", "a", "i", "raan", "argp", "f0") if k in p}
        if "e" in p and "a" not in p and hold == "perigee":
            elements["a"] = r_p / (1.0 - p["e"])
        orbit = o.replace(**elements)
        duration = p["duration"] if "duration" in p else (
            p.get("revolutions", revolutions) * orbit.period)
        return base.replace(orbit=orbit, duration=duration, x0=p.get("x0", base.x0),
                            xf=p.get("xf", base.xf))

    return build


def _check_transfer_parameters(base, hold, model):
    def validate(params):
        unknown = sorted(set(params) - set(TRANSFER_PARAMETERS))
        if unknown:
            raise ValueError(f"unknown transfer parameters {unknown}; allowed: "
                             f"{list(TRANSFER_PARAMETERS)}")
        if "revolutions" in params and "duration" in params:
            raise ValueError("give the duration as 'revolutions' or as 'duration', not both")
        for name in ("x0", "xf"):
            if name in params and params[name].shape[1:] != (6,):
                raise ValueError(f"{name} must have shape (members, 6), got {params[name].shape}")
        e = params.get("e", np.asarray(base.orbit.e))
        if np.any(e < 0.0) or np.any(e >= 1.0):
            raise ValueError(f"e must be in [0, 1) (elliptic chief), got values in "
                             f"[{e.min()}, {e.max()}]")
        a = params.get("a")
        if a is None:
            o = base.orbit
            a = (np.asarray(o.a * (1.0 - o.e)) / (1.0 - e) if hold == "perigee"
                 else np.full_like(e, float(o.a)))
        if model != "linear" and not np.all(perigee_above_surface(a, e, float(base.r_eq))):
            raise ValueError(f"the {model!r} model needs the chief's perigee radius "
                             f"a (1 - e) above r_eq = {float(base.r_eq)} m (hold={hold!r}); got "
                             f"a minimum of {np.min(a * (1.0 - e))} m; lower e or hold the "
                             f"perigee radius")
        for name in ("revolutions", "duration"):
            if name in params and not np.all(params[name] > 0.0):
                raise ValueError(f"{name} must be positive, got a minimum of "
                                 f"{params[name].min()}")

    return validate


def transfer_record(method: str) -> Callable:
    """(problem, grid) -> the record a sweep stores per member: status, cost (1/2 int |u|^2 dt,
    m^2/s^3), cost_true_anomaly (k^2 * cost, m^2/s^4), delta_v (int |u| dt, m/s), constraint
    and stationarity residuals, the largest nodal control |u| (m/s^2) and, for "newton", the
    iterations; initial_control (3,), u at the first node (t0 on LGL and LGR grids, m/s^2)."""
    if method not in TRANSFER_METHODS:
        raise ValueError(f"method must be one of {sorted(TRANSFER_METHODS)}, got {method!r}")

    def record(problem, grid):
        sol = solve(problem.replace(model=TRANSFER_METHODS[method]), grid, method=method,
                    throw=False)
        out = dict(status=sol.status, cost=sol.cost,
                   cost_true_anomaly=sol.stats["cost_true_anomaly"], delta_v=sol.delta_v,
                   constraint_residual=sol.stats["constraint_residual"],
                   stationarity_residual=sol.stats["stationarity_residual"],
                   max_control=jnp.max(jnp.linalg.norm(sol.node_controls, axis=1)),
                   initial_control=sol.node_controls[0])
        if method == "newton":
            out["iterations"] = sol.stats["iterations"].astype(jnp.int32)
        return out

    return record


def sensitivity_family(family: Family, wrt=None, control_gain: bool = True) -> Family:
    """`family` with derivatives added to its record (the family must be a `transfer_family`
    or have the same record names):

      d<name>_d<p>    d cost / d p and d delta_v / d p for each member parameter p in `wrt`
                      (default: every parameter of the table), through the family's builder,
                      so its conventions hold (e with the perigee radius held, say); an array
                      parameter (x0, xf) gives an array of partials
      control_gain    (3, 6) d u(t0) / d x0 (the record's initial_control), the initial
                      optimal control's Jacobian with respect to the initial LVLH state: the
                      neighbouring-optimal feedback gain (1/s^2, 1/s)

    Derivatives of a solution are those of the solver: for the LQ laws autodiff through their
    linear solve (which is the implicit-function theorem for a linear KKT system), for
    Newton-KKT the implicit function theorem at the KKT point (`jaxlpm.implicit`). Reverse
    mode (`jax.jacrev`): one adjoint solve per output (cost, delta_v, the 3 components of
    u(t0)); the library's implicit derivatives (Kepler's equation, the KKT point) are
    custom_vjp rules, which forward mode cannot use.
    """
    def build(p):
        return p

    def record(p, grid):
        names = sorted(p) if wrt is None else list(wrt)
        q = {k: p[k] for k in names}
        if control_gain and "x0" not in q:
            q["x0"] = family.build(p).x0

        def outputs(q):
            r = family.solve(family.build({**p, **q}), grid)
            return {k: r[k] for k in ("cost", "delta_v", "initial_control")}, r

        jac, rec = jax.jacrev(outputs, has_aux=True)(q)
        for out_name in ("cost", "delta_v"):
            for k in names:
                rec[f"d{out_name}_d{k}"] = jac[out_name][k]
        if control_gain:
            rec["control_gain"] = jac["initial_control"]["x0"]
        return rec

    def validate(params):
        if family.validate is not None:
            family.validate(params)
        unknown = sorted(set(wrt or ()) - set(params))
        if unknown:
            raise ValueError(f"wrt names {unknown} are not parameters of the table "
                             f"{sorted(params)}")

    definition = dict(family.definition, sensitivities=dict(
        wrt=None if wrt is None else list(wrt), control_gain=control_gain))
    # the gradients' tangent solves (implicit differentiation) are LAPACK calls
    return Family(name=family.name, build=build, solve=record, grid=family.grid,
                  definition=definition, min_N=family.min_N, validate=validate,
                  cpu_batch_size=1)


def transfer_family(name: str, base: EnergyOptimalTransfer, method: str = "kkt",
                    hold: str = "perigee") -> Family:
    """Energy-optimal transfers about `base` (see `transfer_builder` for the parameters),
    solved by `method`: "kkt" or "stm" (Mei 2010's linear laws, linear model) or "newton"
    (Newton-KKT on the nonlinear two-body model). N is the polynomial degree: grid lgl(N + 1)
    (Mei 2010's convention), N >= 3."""
    o = base.orbit
    definition = dict(
        problem="EnergyOptimalTransfer", method=method, model=TRANSFER_METHODS.get(method),
        grid="lgl(N + 1): N is the polynomial degree",
        held_when_e_varies=("perigee radius r_p = a (1 - e) of the base orbit" if hold == "perigee"
                            else "semi-major axis a of the base orbit"),
        base=dict(a=float(o.a), e=float(o.e), r_p=float(o.a * (1.0 - o.e)), i=float(o.i),
                  raan=float(o.raan), argp=float(o.argp), f0=float(o.f0), mu=float(o.mu),
                  revolutions=float(base.duration / o.period), duration=float(base.duration),
                  x0=np.asarray(base.x0).tolist(), xf=np.asarray(base.xf).tolist(),
                  thrust_axes=list(base.thrust_axes)),
        record="status, cost (m^2/s^3), cost_true_anomaly (m^2/s^4), delta_v (m/s), "
               "constraint_residual, stationarity_residual, max_control (m/s^2), "
               "initial_control (m/s^2)"
               + (", iterations" if method == "newton" else ""))
    return Family(name=name, build=transfer_builder(base, hold), solve=transfer_record(method),
                  grid=lambda N: lgl(N + 1), definition=definition, min_N=3,
                  validate=_check_transfer_parameters(base, hold, TRANSFER_METHODS.get(method)),
                  cpu_batch_size=None if method == "stm" else 1)


def parameter_grid(**axes) -> dict:
    """The Cartesian product of 1-D parameter axes as a member table (first axis slowest):
    parameter_grid(e=[0, 0.1], revolutions=[1, 2, 3]) has 6 members."""
    if not axes:
        raise ValueError("parameter_grid needs at least one axis")
    arrays = {k: np.asarray(v, dtype=np.float64) for k, v in axes.items()}
    for k, v in arrays.items():
        if v.ndim != 1 or v.size == 0:
            raise ValueError(f"axis {k!r} must be a non-empty 1-D array, got shape {v.shape}")
    mesh = np.meshgrid(*arrays.values(), indexing="ij")
    return {k: m.ravel() for k, m in zip(arrays, mesh)}


# ------------------------------------------------------------------------------------------
# files


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


def _read_chunk(path: Path, sha256: str | None = None) -> tuple[dict, str]:
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
                arrays, sha256 = _read_chunk(f, (log or {}).get("sha256"))
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


# ------------------------------------------------------------------------------------------
# the sweep


@dataclass(frozen=True)
class SweepResult:
    """A sweep's results: `tables[N]` maps column names (index, N, the parameters, the
    solver's outputs) to arrays in member order; `out` is the results directory (or None)."""

    tables: dict
    out: Path | None = None

    def converged(self) -> dict:
        """Members with status SUCCESS, per N."""
        return {N: int(np.sum(t["status"] == Status.SUCCESS)) for N, t in self.tables.items()}

    def failed(self) -> dict:
        """Member indices whose status is not SUCCESS, per N (never averaged in: filter on
        `status == 0` before taking statistics)."""
        return {N: t["index"][t["status"] != Status.SUCCESS] for N, t in self.tables.items()}

    def summary(self) -> dict:
        failed = self.failed()
        out = {}
        for N, t in self.tables.items():
            codes, counts = np.unique(t["status"], return_counts=True)
            out[str(N)] = dict(members=int(t["index"].size), converged=self.converged()[N],
                               status_counts={_status_name(c): int(k)
                                              for c, k in zip(codes, counts)},
                               not_converged=failed[N].tolist())
        return out


    def statistics(self, columns=("cost", "delta_v"), percentiles=PERCENTILES) -> dict:
        """Per N and column: `converged_statistics` over the members with status SUCCESS."""
        return {N: {c: converged_statistics(t[c], t["status"], percentiles) for c in columns}
                for N, t in self.tables.items()}



def converged_statistics(values, status, percentiles=PERCENTILES) -> dict:
    """Statistics of `values` (one per member, leading axis) over the members whose `status`
    is SUCCESS only: members, converged, not_converged (their indices), and over the converged
    members mean, std, min, max and the given percentiles (NaN when none converged)."""
    values, status = np.asarray(values, dtype=np.float64), np.asarray(status)
    ok = status == Status.SUCCESS
    good = values[ok]
    stat = (lambda fn: fn(good, axis=0)) if good.size else (lambda fn: np.nan)
    return dict(members=int(status.size), converged=int(ok.sum()),
                not_converged=np.flatnonzero(~ok).tolist(), mean=stat(np.mean),
                std=stat(np.std), min=stat(np.min), max=stat(np.max),
                percentiles={float(q): (np.percentile(good, q, axis=0) if good.size else np.nan)
                             for q in percentiles})


def _status_name(code) -> str:
    try:
        return Status(int(code)).name
    except ValueError:
        return f"UNKNOWN({int(code)})"


def _check_sweep_inputs(family, params, Ns, chunk_size, batch_size):
    if not isinstance(params, dict) or not params:
        raise ValueError("params must be a non-empty dict of arrays with a common leading "
                         "(member) axis")
    params = {k: np.asarray(v) for k, v in params.items()}
    sizes = {k: (v.shape[0] if v.ndim else None) for k, v in params.items()}
    if None in sizes.values() or len(set(sizes.values())) != 1:
        raise ValueError(f"every parameter needs the same leading (member) axis; got leading "
                         f"sizes {sizes}")
    members = next(iter(sizes.values()))
    if members == 0:
        raise ValueError("the parameter table has no members")
    for k, v in params.items():
        if not (np.issubdtype(v.dtype, np.floating) or np.issubdtype(v.dtype, np.integer)):
            raise ValueError(f"parameter {k!r} must be numeric, got dtype {v.dtype}")
        if np.issubdtype(v.dtype, np.floating):
            params[k] = v.astype(np.float64)
            if not np.all(np.isfinite(v)):
                raise ValueError(f"parameter {k!r} has non-finite values")
    for reserved in ("index", "N", "compute_log"):
        if reserved in params:
            raise ValueError(f"{reserved!r} is a reserved column name, rename that parameter")
    Ns = np.atleast_1d(np.asarray(Ns))
    if Ns.ndim != 1 or Ns.size == 0 or not np.issubdtype(Ns.dtype, np.integer):
        raise ValueError(f"Ns must be a non-empty list of integers, got {Ns!r}")
    if Ns.min() < family.min_N:
        raise ValueError(f"family {family.name!r} needs N >= {family.min_N}, got {Ns.tolist()}")
    for name, value in (("chunk_size", chunk_size), ("batch_size", batch_size)):
        if value is not None and (isinstance(value, bool) or int(value) != value or value < 1):
            raise ValueError(f"{name} must be a positive integer, got {value!r}")
    if family.validate is not None:
        family.validate(params)
    return params, sorted({int(N) for N in Ns}), members


def _digest(x: np.ndarray) -> str:
    return hashlib.sha256(np.ascontiguousarray(x).tobytes()).hexdigest()


def sweep_definition(family: Family, params: dict, Ns, chunk_size: int) -> dict:
    """What determines a sweep's results and layout (recorded in and checked against the
    manifest): the family, its definition, the Ns, the chunk size and the parameter table."""
    return dict(family=family.name, family_definition=family.definition, Ns=list(Ns),
                chunk_size=int(chunk_size), members=int(next(iter(params.values())).shape[0]),
                parameters={k: dict(shape=list(v.shape[1:]), dtype=str(v.dtype),
                                    min=float(v.min()), max=float(v.max()), sha256=_digest(v))
                            for k, v in params.items()})


def _chunk_function(family, grid, batch_size, mesh):
    """jit(shard_map(lax.map(solve . build))): each device solves its own block of a chunk,
    `batch_size` members at a time by vmap. shard_map (rather than vmap over a device axis)
    keeps devices independent: an iterative solver's while loop is not run in lockstep
    across devices (no all-reduce of its stopping test)."""
    def one(p):
        return family.solve(family.build(p), grid)

    def block(ps):
        return map_in_groups(one, ps, batch_size)

    # check_vma=False: the blocks never communicate, and the varying-axes type check rejects
    # the cotangents of custom_vjp rules (jaxopt's implicit diff) under reverse mode.
    return jax.jit(jax.shard_map(block, mesh=mesh, in_specs=P("batch"), out_specs=P("batch"),
                                 check_vma=False))


@dataclass(frozen=True)
class _Layout:
    """How a chunk is cut: `per_device` members per device (a multiple of `width`, the
    vmapped batch of lax.map), `devices` devices over all processes, `rows` = their product
    (a chunk padded to this fixed shape)."""

    chunk_size: int
    devices: int
    per_device: int
    width: int

    @property
    def rows(self):
        return self.devices * self.per_device


def _layout(chunk_size, batch_size, devices) -> _Layout:
    per_device = -(-chunk_size // devices)
    width = min(batch_size or per_device, per_device)
    per_device = -(-per_device // width) * width          # lax.map without a remainder batch
    return _Layout(chunk_size, devices, per_device, width)


def sweep(family: Family, params: dict, Ns, out=None, chunk_size: int = 256,
          batch_size: int | None = None, progress: bool = True, run_info: dict | None = None,
          compiler_options: dict | None = None) -> SweepResult:
    """Solve `family` for every member of `params` at every N in `Ns`.

    params      dict of arrays with a common leading (member) axis (`parameter_grid` makes
                one from axes); validated on the host (ValueError)
    Ns          grid sizes in the family's convention; grouped (one compiled function each)
    out         results directory (resumable, see the module docstring), or None: in memory
    chunk_size  members per chunk (part of the definition: fixes the files' layout)
    batch_size  members a device solves at once by vmap inside its lax.map (default: on CPU the
                family's cpu_batch_size, else all its members of the chunk); smaller bounds
                memory, and for iterative solvers stops one slow member from holding a wide
                batch in lockstep
    run_info    extra JSON-able facts about this invocation for the manifest's `runs`
    compiler_options  passed to XLA's compile (e.g. {"xla_backend_optimization_level": 0}
                compiles large solvers faster and runs them slower)
    batch_size, the device count and compiler_options are not part of the definition: a
    resumed sweep may change them, which changes results at round-off level only (the vmap
    width changes how XLA vectorises a member's arithmetic)
    Returns the `SweepResult` (all chunks, including those of earlier runs).

    Devices: all of `jax.devices()` (every process's, after `jax.distributed.initialize`).
    With several processes every process runs the same call; each computes its devices'
    blocks, and process 0 alone reads and writes `out` (a shared filesystem is not needed)
    and returns the results; the others return an empty `SweepResult` (with out=None every
    process returns them all).
    """
    require_x64()
    if batch_size is None and jax.default_backend() == "cpu":
        batch_size = family.cpu_batch_size
    params, Ns, members = _check_sweep_inputs(family, params, Ns, chunk_size, batch_size)
    chunk_size = min(int(chunk_size), members)
    n_chunks = -(-members // chunk_size)
    lay = _layout(chunk_size, batch_size, jax.device_count())
    mesh = jax.make_mesh((lay.devices,), ("batch",), axis_types=(jax.sharding.AxisType.Auto,))
    sharding = NamedSharding(mesh, P("batch"))
    lead = jax.process_index() == 0
    definition = sweep_definition(family, params, Ns, chunk_size)
    store = None
    if out is not None and lead:
        store = ChunkStore(out, definition, dict(
            started=time.strftime("%Y-%m-%d %H:%M:%S %Z"), argv=sys.argv, host=platform.node(),
            cpu_count=os.cpu_count(), jax=jax.__version__, backend=jax.default_backend(),
            processes=jax.process_count(), devices=lay.devices, batch_size=batch_size,
            **(run_info or {})))
    done = {}                                    # (N, chunk) -> arrays, for out=None

    def chunk_members(c):
        idx = np.arange(c * chunk_size, min((c + 1) * chunk_size, members))
        pad = np.concatenate([idx, np.full(lay.rows - idx.size, idx[0])])
        batch = {k: jax.make_array_from_callback((lay.rows, *v.shape[1:]), sharding,
                                                 lambda i, v=v[pad]: v[i])
                 for k, v in params.items()}
        return idx, batch

    todo = np.array([[store is None or not store.done(f"N{N}", f"chunk_{c:05d}")
                      for c in range(n_chunks)] for N in Ns])
    if jax.process_count() > 1 and out is not None:   # process 0 read the directory
        todo = np.asarray(multihost_utils.broadcast_one_to_all(todo))
    bar = tqdm(total=int(todo.sum()), desc=f"sweep {family.name}", unit="chunk",
               disable=not (progress and lead), dynamic_ncols=True)
    for row, N in enumerate(Ns):
        mine = np.flatnonzero(todo[row]).tolist()
        if not mine:
            continue
        t = time.perf_counter()
        lowered = _chunk_function(family, family.grid(N), lay.width, mesh).lower(
            chunk_members(mine[0])[1])
        clash = set(lowered.out_info) & (set(params) | {"index", "N", "compute_log"})
        if clash or "status" not in lowered.out_info:
            raise ValueError(f"family {family.name!r}: the solver's record needs a 'status' and "
                             f"no name of a parameter or index/N/compute_log; clashes: "
                             f"{sorted(clash)}")
        compiled = lowered.compile(compiler_options)
        compile_s = time.perf_counter() - t
        if store is not None:
            store.update(compiles=dict(run=store.run, N=N, seconds=compile_s))
        for c in mine:
            idx, batch = chunk_members(c)
            t = time.perf_counter()
            rec = _gather(jax.block_until_ready(compiled(batch)))
            seconds = time.perf_counter() - t
            rec = {k: v[:idx.size] for k, v in rec.items()}
            arrays = dict(index=idx, N=np.full(idx.size, N),
                          **{k: v[idx] for k, v in params.items()}, **rec)
            converged = int(np.sum(rec["status"] == Status.SUCCESS))
            if out is None:
                done[(N, c)] = arrays
            elif store is not None:
                store.write(f"N{N}", f"chunk_{c:05d}", arrays, dict(
                    seconds=seconds, devices=lay.devices, batch_size=batch_size,
                    members=int(idx.size), converged=converged,
                    finished=time.strftime("%Y-%m-%d %H:%M:%S %Z")))
            bar.update()
            bar.set_postfix(N=N, converged=f"{converged}/{idx.size}")
    bar.close()
    if out is None:
        tables = {N: _concatenate([done[(N, c)] for c in range(n_chunks)]) for N in Ns}
        return SweepResult(tables)
    if store is None:                             # not process 0: nothing was written here
        return SweepResult({}, Path(out))
    result = load_sweep(store.out)
    store.update(summary=result.summary())
    return result


def _gather(tree) -> dict:
    """A chunk's outputs as host NumPy arrays (from every process's devices)."""
    if jax.process_count() > 1:
        return {k: np.asarray(v) for k, v in
                multihost_utils.process_allgather(tree, tiled=True).items()}
    return {k: np.asarray(v) for k, v in tree.items()}


def _concatenate(chunks):
    return {k: np.concatenate([c[k] for c in chunks]) for k in chunks[0]}


def load_sweep(out) -> SweepResult:
    """Read a sweep directory; ValueError if a chunk is missing (an unfinished sweep: re-run
    its command to complete it) or corrupt (naming the file: re-running the command computes
    it again)."""
    out = Path(out)
    path = out / MANIFEST
    if not path.exists():
        raise ValueError(f"{out} is not a sweep directory (no {MANIFEST})")
    m = json.loads(path.read_text())
    d = m["definition"]
    n_chunks = -(-d["members"] // d["chunk_size"])
    tables = {}
    for N in d["Ns"]:
        files = [out / f"N{N}" / f"chunk_{c:05d}.npz" for c in range(n_chunks)]
        missing = [f.name for f in files if not f.exists()]
        if missing:
            raise ValueError(f"{out} is incomplete: N = {N} lacks {len(missing)} of {n_chunks} "
                             f"chunks ({', '.join(missing[:5])}...); re-run the sweep's command")
        chunks = []
        for f in files:
            arrays, _ = _read_chunk(f, m["chunks"].get(f"N{N}/{f.stem}", {}).get("sha256"))
            del arrays["compute_log"]
            chunks.append(arrays)
        tables[N] = _concatenate(chunks)
    return SweepResult(tables, out)
