"""Parameter sweeps of any problem family: one compiled function per grid size (a number of
points), fixed-shape chunks sharded across every device (of every process), each finished
chunk written to disk as it goes, resumable.

A sweep solves a `SweepFamily` (`jaxlpm.batch.family`: how to build one problem from one
member's parameters, the solve settings, what to record) for every member of a parameter
table (a dict of arrays with a common leading axis, e.g. from `parameter_grid` or
`problem_table`) at every point count of a list:

    for each point count (ascending): grid = family.grid(points); one function
        jit(shard_map(lax.map(record(solve(build(member), grid)), batch_size)))
    compiled ahead of time once, for one chunk shape: members are taken `chunk_size` at a time
    in order, the last chunk padded with copies of its first member (so nothing recompiles);
    a chunk of devices x per_device rows is placed on P("batch") of the mesh
    jax.make_mesh((devices,), ("batch",), AxisType.Auto), each device solving its own block
    (no communication); lax.map with `batch_size` bounds the members a device holds in flight.

On disk (`jaxlpm.batch.store.ChunkStore`), under `out`:
    manifest.json          schema_version, the sweep's `definition` (family, its settings, the
                           point counts, chunk size, parameter names, shapes and SHA-256),
                           `runs` (one entry per invocation), `compiles` (seconds per point
                           count and run), `chunks` ({"points17/chunk_00003": compute log:
                           run, seconds, devices, members, converged, finished, and the file's
                           sha256}) and, once complete, `summary` (per point count: members,
                           converged, status counts, the non-SUCCESS member indices).
    points<n>/chunk_XXXXX.npz   one finished chunk: index (member numbers), points, the
                           members' parameters and their records, one row per member;
                           `pandas.DataFrame({k: v for k, v in np.load(f).items() if v.ndim == 1})`.
Files are written to a temporary name and renamed (atomic), so a killed run loses at most the
chunk in flight; re-running the same sweep skips the chunks on disk, and a directory made by a
different definition is refused with a ValueError naming what differs. A chunk file that is
missing, unreadable (truncated, empty) or differs from its logged SHA-256 is removed and
computed again by the rerun (with a warning); `load_sweep` refuses it with a ValueError naming
the file. Statistics (`SweepResult.statistics`, `converged_statistics`) are taken over the
SUCCESS members only; the others are counted by status and listed.

The persistent compilation cache is the caller's to configure (the `jaxlpm sweep` CLI does);
with it a rerun skips compilation too.
"""

import hashlib
import json
import os
import platform
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import jax
import numpy as np
from jax.experimental import multihost_utils
from jax.sharding import NamedSharding, PartitionSpec as P
from tqdm import tqdm

from .._validation import require_x64
from ..status import Status
from ..mapping import map_in_groups
from .family import SweepFamily, solve_member
from .refine import Refinement, check_refinement, climb, masked, refinement_plan, rung_member
from .store import MANIFEST, SCHEMA_VERSION, ChunkStore, read_chunk

PERCENTILES = (5.0, 50.0, 95.0)       # reported by default with the mean and spread
RESERVED = ("index", "points", "compute_log", "rung", "segments")
REFINE = "refine"      # the group of a sweep solved by adaptive mesh refinement


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
# the sweep


@dataclass(frozen=True)
class SweepResult:
    """A sweep's results: `tables[points]` maps column names (index, points, the parameters,
    the records) to arrays in member order; `out` is the results directory (or None)."""

    tables: dict
    out: Path | None = None

    def converged(self) -> dict:
        """Members with status SUCCESS, per point count."""
        return {n: int(np.sum(t["status"] == Status.SUCCESS)) for n, t in self.tables.items()}

    def failed(self) -> dict:
        """Member indices whose status is not SUCCESS, per point count (never averaged in:
        `statistics` leaves them out)."""
        return {n: t["index"][t["status"] != Status.SUCCESS] for n, t in self.tables.items()}

    def summary(self) -> dict:
        """Per point count (a string key, for JSON): members, converged, status_counts
        ({status name: members}) and not_converged (the non-SUCCESS member indices)."""
        converged, failed = self.converged(), self.failed()
        out = {}
        for n, t in self.tables.items():
            codes, counts = np.unique(t["status"], return_counts=True)
            out[str(n)] = dict(members=int(t["index"].size), converged=converged[n],
                               status_counts={_status_name(c): int(k)
                                              for c, k in zip(codes, counts)},
                               not_converged=failed[n].tolist())
        return out

    def statistics(self, columns=("cost", "delta_v"), percentiles=PERCENTILES) -> dict:
        """Per point count and column: `converged_statistics` over the SUCCESS members."""
        return {n: {c: converged_statistics(t[c], t["status"], percentiles) for c in columns}
                for n, t in self.tables.items()}


def converged_statistics(values, status, percentiles=PERCENTILES) -> dict:
    """Statistics of `values` (one per member, leading axis) over the members whose `status`
    is SUCCESS only: members, converged, not_converged (the others' indices), and over the
    converged members mean, std, min, max and the given percentiles (NaN when none
    converged)."""
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


def _check_sweep_inputs(family, params, points, chunk_size, batch_size):
    if not isinstance(family, SweepFamily):
        raise ValueError(f"family must be a SweepFamily, got {type(family).__name__}")
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
            if np.any(np.isnan(v)):
                raise ValueError(f"parameter {k!r} has NaN values")
    for reserved in RESERVED:
        if reserved in params:
            raise ValueError(f"{reserved!r} is a reserved column name, rename that parameter")
    items = [points] if isinstance(points, (str, int, np.integer)) else list(points)
    refine = REFINE in items
    counts = np.asarray([v for v in items if not (isinstance(v, str) and v == REFINE)])
    if ((not refine and counts.size == 0) or counts.ndim != 1
            or (counts.size and (not np.issubdtype(counts.dtype, np.integer)
                                 or counts.min() < 1))):
        raise ValueError(f"points must be a non-empty list of positive integers (grid sizes "
                         f"in points: lgl(17) has 17) and/or {REFINE!r} (adaptive mesh "
                         f"refinement), got {points!r}")
    for name, value in (("chunk_size", chunk_size), ("batch_size", batch_size)):
        if value is not None and (isinstance(value, bool) or int(value) != value or value < 1):
            raise ValueError(f"{name} must be a positive integer, got {value!r}")
    if family.validate is not None:
        family.validate(params)
    return params, sorted({int(n) for n in counts}) + ([REFINE] if refine else []), members


def _digest(x: np.ndarray) -> str:
    return hashlib.sha256(np.ascontiguousarray(x).tobytes()).hexdigest()


def sweep_definition(family: SweepFamily, params: dict, points, chunk_size: int,
                     refinement: dict | None = None) -> dict:
    """What determines a sweep's results and layout (recorded in and checked against the
    manifest): the family's name and settings, the point counts (and "refine"), the chunk
    size, the parameter table and, with a "refine" group, its `Refinement` settings and
    method."""
    out = dict(family=family.name, family_definition=family.settings(), points=list(points),
               chunk_size=int(chunk_size), members=int(next(iter(params.values())).shape[0]),
               parameters={k: dict(shape=list(v.shape[1:]), dtype=str(v.dtype),
                                   min=float(v.min()), max=float(v.max()), sha256=_digest(v))
                           for k, v in params.items()})
    if refinement is not None:
        out["refinement"] = refinement
    return out


def _sharded(member, batch_size, mesh):
    """jit(shard_map(lax.map(member))): each device solves its own block of a chunk,
    `batch_size` members at a time by vmap. shard_map (rather than vmap over a device axis)
    keeps devices independent: an iterative solver's while loop is not run in lockstep
    across devices (no all-reduce of its stopping test)."""
    def block(*xs):
        return map_in_groups(member, xs if len(xs) > 1 else xs[0], batch_size)

    # check_vma=False: the blocks never communicate, and the varying-axes type check rejects
    # the cotangents of custom_vjp rules (jaxopt's implicit diff) under reverse mode.
    return jax.jit(jax.shard_map(block, mesh=mesh, in_specs=P("batch"), out_specs=P("batch"),
                                 check_vma=False))


def _on_devices(v: np.ndarray, sharding):
    """A host array of a chunk's rows placed on the devices of `sharding` (every process
    builds the blocks of its own devices)."""
    return jax.make_array_from_callback(v.shape, sharding, lambda i: v[i])


def _chunk_function(family, grid, batch_size, mesh):
    """A chunk on `grid`: family.evaluate of each member (`_sharded`)."""
    return _sharded(lambda p: family.evaluate(p, grid), batch_size, mesh)


def _rung_function(plan, shape, previous, refinement, family, batch_size, mesh):
    """A chunk on one rung of the refinement: (params, breaks, carry, active) -> (records,
    carry), each member built by the family and solved by the plan where active
    (`jaxlpm.batch.refine.rung_member`, `masked`)."""
    member = masked(rung_member(plan, shape, previous, refinement, family.record,
                                build=family.build))
    return _sharded(lambda args: member((args[:3], args[3])), batch_size, mesh)


class _RefinedChunks:
    """The "refine" group of a sweep: every chunk climbs the plan's ladder (`climb`), each
    rung one function for the chunk's fixed shape, compiled at its first use and kept."""

    def __init__(self, family, params, refinement, lay, mesh, sharding, compiler_options):
        if family.solver is not solve_member:
            raise ValueError(f"family {family.name!r} has its own solver; a {REFINE!r} group "
                             f"solves each member by its family's refinement (as "
                             f"`jaxlpm.solve(problem)` without a grid): derivatives come "
                             f"from Refinement(gradients=True), not sensitivity_family")
        self.refinement = refinement or Refinement()
        problems = jax.vmap(family.build)(params)
        self.plan = refinement_plan(problems, self.refinement.ladder, family.options)
        check_refinement(self.plan, self.refinement)
        self.family, self.lay, self.mesh, self.sharding = family, lay, mesh, sharding
        self.compiler_options = compiler_options
        self.compiled, self.compile_s = {}, {}

    def settings(self) -> dict:
        """The refinement's part of the sweep's definition; the ladder's scheme where it is not
        LGR (a sweep refined on LG or LGL meshes is another sweep; LGR ladders keep the
        definition that sweeps written before the scheme was recorded resume from)."""
        out = dict(self.refinement.settings(), method=self.plan.method,
                   rungs=[list(r) for r in self.plan.ladder.rungs])
        if self.plan.ladder.scheme != "LGR":
            out["scheme"] = self.plan.ladder.scheme
        return out


    def __call__(self, batch, members: int) -> dict:
        """One chunk's records (`lay.rows` rows, the first `members` of them real)."""
        active = np.arange(self.lay.rows) < members

        def run_rung(index, shape, previous, breaks, carry, act):
            args = (batch,) + jax.tree_util.tree_map(
                lambda v: _on_devices(np.asarray(v), self.sharding), (breaks, carry, act))
            if index not in self.compiled:
                t = time.perf_counter()
                fn = _rung_function(self.plan, shape, previous if self.plan.warm_start else None,
                                    self.refinement, self.family, self.lay.width, self.mesh)
                lowered = fn.lower(*args)
                clash = set(lowered.out_info[0]) & (set(batch) | set(RESERVED))
                if clash or "status" not in lowered.out_info[0]:
                    raise ValueError(f"family {self.family.name!r}: the record needs a 'status' "
                                     f"and no name of a parameter or of {RESERVED}; clashes: "
                                     f"{sorted(clash)}")
                self.compiled[index] = lowered.compile(self.compiler_options)
                self.compile_s[index] = time.perf_counter() - t
            return _gather(jax.block_until_ready(self.compiled[index](*args)))

        return climb(self.plan, self.lay.rows, active, run_rung)


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


def _group(points) -> str:
    return "refined" if points == REFINE else f"points{points}"


def _lower(family, points, width, mesh, batch, params):
    """The chunk function at `points` lowered for `batch` (tracing the solver: a bad method,
    options or grid size raises its ValueError here), its record's names checked."""
    lowered = _chunk_function(family, family.grid(points), width, mesh).lower(batch)
    clash = set(lowered.out_info) & (set(params) | set(RESERVED))
    if clash or "status" not in lowered.out_info:
        raise ValueError(f"family {family.name!r}: the record needs a 'status' and no name of a "
                         f"parameter or of {RESERVED}; clashes: {sorted(clash)} (rename the "
                         f"parameters or give the family a record of your own)")
    return lowered


def sweep(family: SweepFamily, params: dict, points, out=None, chunk_size: int = 256,
          batch_size: int | None = None, progress: bool = True, run_info: dict | None = None,
          compiler_options: dict | None = None,
          refinement: Refinement | None = None) -> SweepResult:
    """Solve `family` for every member of `params` at every grid size in `points`, and by
    adaptive mesh refinement where `points` holds "refine".

    params      dict of arrays with a common leading (member) axis (`parameter_grid` makes
                one from axes, `problem_table` from a batched problem); validated on the host
                (ValueError)
    points      grid sizes as numbers of points (`family.grid(n)`: lgl(17) has 17 points, Mei
                2010's degree N = 16); grouped, one compiled function each. The smallest is
                traced before anything is written, so a method, options or grid size the
                solver refuses raises its ValueError and leaves no directory.
                "refine" (after the point counts; its table's key and the folder `refined`):
                every member solved as `jaxlpm.solve(problem)` solves it without a grid, by
                its family's refinement (`jaxlpm.batch.refine`: Newton-KKT on the
                `MeshLadder`, the fuel family's aligned meshes, minimum time's ladder; the
                family's method is not used, its options are) until the error estimate meets
                the tolerance. Each chunk solves all its members on the first rung, then only
                its INACCURATE ones on the next (one compiled function per rung for the
                chunk's shape, the others skipped, warm-started where the family is); the
                record gains "rung" and "segments" (the final mesh's)
    out         results directory (resumable, see the module docstring), or None: in memory
    chunk_size  members per chunk (part of the definition: fixes the files' layout)
    batch_size  members a device solves at once by vmap inside its lax.map (default: on CPU the
                family's cpu_batch_size, else all its members of the chunk); smaller bounds
                memory, and for iterative solvers stops one slow member from holding a wide
                batch in lockstep
    run_info    extra JSON-able facts about this invocation for the manifest's `runs`
    compiler_options  passed to XLA's compile (e.g. {"xla_backend_optimization_level": 0}
                compiles large solvers faster and runs them slower)
    refinement  the "refine" group's `jaxlpm.batch.refine.Refinement` (ladder, tolerance,
                gradients; None: `Refinement()`, the family's ladder and `DEFAULT_TOLERANCE`);
                part of the definition
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
    params, points, members = _check_sweep_inputs(family, params, points, chunk_size,
                                                  batch_size)
    chunk_size = min(int(chunk_size), members)
    n_chunks = -(-members // chunk_size)
    lay = _layout(chunk_size, batch_size, jax.device_count())
    mesh = jax.make_mesh((lay.devices,), ("batch",), axis_types=(jax.sharding.AxisType.Auto,))
    sharding = NamedSharding(mesh, P("batch"))
    lead = jax.process_index() == 0
    refined = (_RefinedChunks(family, params, refinement, lay, mesh, sharding, compiler_options)
               if REFINE in points else None)
    definition = sweep_definition(family, params, points, chunk_size,
                                  None if refined is None else refined.settings())

    def chunk_members(c):
        idx = np.arange(c * chunk_size, min((c + 1) * chunk_size, members))
        pad = np.concatenate([idx, np.full(lay.rows - idx.size, idx[0])])
        batch = {k: _on_devices(v[pad], sharding) for k, v in params.items()}
        return idx, batch

    t = time.perf_counter()
    first = (None if points[0] == REFINE
             else _lower(family, points[0], lay.width, mesh, chunk_members(0)[1], params))
    first_s = time.perf_counter() - t
    store = None
    if out is not None and lead:
        store = ChunkStore(out, definition, dict(
            started=time.strftime("%Y-%m-%d %H:%M:%S %Z"), argv=sys.argv, host=platform.node(),
            cpu_count=os.cpu_count(), jax=jax.__version__, backend=jax.default_backend(),
            processes=jax.process_count(), devices=lay.devices, batch_size=batch_size,
            **(run_info or {})))
    done = {}                                    # (points, chunk) -> arrays, for out=None
    todo = np.array([[store is None or not store.done(_group(n), f"chunk_{c:05d}")
                      for c in range(n_chunks)] for n in points])
    if jax.process_count() > 1 and out is not None:   # process 0 read the directory
        todo = np.asarray(multihost_utils.broadcast_one_to_all(todo))
    bar = tqdm(total=int(todo.sum()), desc=f"sweep {family.name}", unit="chunk",
               disable=not (progress and lead), dynamic_ncols=True)
    for row, n in enumerate(points):
        mine = np.flatnonzero(todo[row]).tolist()
        if not mine:
            continue
        if n == REFINE:
            compiled = refined
        else:
            t = time.perf_counter()
            lowered = first if row == 0 else _lower(family, n, lay.width, mesh,
                                                    chunk_members(mine[0])[1], params)
            compiled = lowered.compile(compiler_options)
            compile_s = time.perf_counter() - t + (first_s if row == 0 else 0.0)
            if store is not None:
                store.update(compiles=dict(run=store.run, points=n, seconds=compile_s))
        for c in mine:
            idx, batch = chunk_members(c)
            t = time.perf_counter()
            if n == REFINE:
                known = set(refined.compiled)
                rec = refined(batch, idx.size)
                compile_s = sum(refined.compile_s[k] for k in set(refined.compiled) - known)
                if store is not None and compile_s:
                    store.update(compiles=dict(run=store.run, points=n, seconds=compile_s))
            else:
                rec, compile_s = _gather(jax.block_until_ready(compiled(batch))), 0.0
            seconds = time.perf_counter() - t - compile_s
            rec = {k: v[:idx.size] for k, v in rec.items()}
            arrays = dict(index=idx, points=np.full(idx.size, n),
                          **{k: v[idx] for k, v in params.items()}, **rec)
            converged = int(np.sum(rec["status"] == Status.SUCCESS))
            if out is None:
                done[(n, c)] = arrays
            elif store is not None:
                store.write(_group(n), f"chunk_{c:05d}", arrays, dict(
                    seconds=seconds, devices=lay.devices, batch_size=batch_size,
                    members=int(idx.size), converged=converged,
                    finished=time.strftime("%Y-%m-%d %H:%M:%S %Z")))
            bar.update()
            bar.set_postfix(points=n, converged=f"{converged}/{idx.size}")
    bar.close()
    if out is None:
        tables = {n: _concatenate([done[(n, c)] for c in range(n_chunks)]) for n in points}
        return SweepResult(tables)
    if store is None:                             # not process 0: nothing was written here
        return SweepResult({}, Path(out))
    result = load_sweep(store.out)
    store.update(summary=result.summary())
    return result


def _gather(tree):
    """A chunk's outputs as host NumPy arrays (from every process's devices)."""
    if jax.process_count() > 1:
        tree = multihost_utils.process_allgather(tree, tiled=True)
    return jax.tree_util.tree_map(np.asarray, tree)


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
    if m.get("schema_version") != SCHEMA_VERSION:
        raise ValueError(f"{path} has schema_version {m.get('schema_version')}, this jaxlpm "
                         f"reads {SCHEMA_VERSION} (grid sizes as point counts): re-run its sweep "
                         f"into a new directory")
    n_chunks = -(-d["members"] // d["chunk_size"])
    tables = {}
    for n in d["points"]:
        files = [out / _group(n) / f"chunk_{c:05d}.npz" for c in range(n_chunks)]
        missing = [f.name for f in files if not f.exists()]
        if missing:
            raise ValueError(f"{out} is incomplete: {n} points lacks {len(missing)} of "
                             f"{n_chunks} chunks ({', '.join(missing[:5])}...); re-run the "
                             f"sweep's command")
        chunks = []
        for f in files:
            arrays, _ = read_chunk(f, m["chunks"].get(f"{_group(n)}/{f.stem}", {}).get("sha256"))
            del arrays["compute_log"]
            chunks.append(arrays)
        tables[n] = _concatenate(chunks)
    return SweepResult(tables, out)
