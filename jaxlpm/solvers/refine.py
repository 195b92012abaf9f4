"""Adaptive hp mesh refinement: solve on a ladder of mesh shapes (`LGRMesh` by default; `LGMesh`
and `LGLMesh` too) until the error estimate meets the tolerance
(Patterson, Hager & Rao 2015; Darby, Hager & Rao 2011).

A `MeshLadder` is a fixed sequence of mesh shapes (segments K, points per segment n) of one
scheme:
each rung compiles once, whatever its breaks (they are an array leaf of the mesh), so a batch
of problems refines rung by rung with one compiled function per rung (`jaxlpm.batch`). From one
rung to the next:
  h (split)   the next rung's K' segments are shared out over the current segments in
              proportion to each one's relative error (`stats["segment_error"]`, Patterson et
              al. eq. 38) to the power `SPLIT_EXPONENT` (largest remainder, at least one
              each), and every current segment is cut evenly into its share: the segments
              that resolve the solution keep one piece, the others are split where the error
              is; a segment where a safety constraint is violated between the nodes beyond
              the tolerance weighs as the least accurate one times the excess to the fourth
              (`jaxlpm.solution.accuracy.refinement_error`);
  p (degree)  a rung that raises n keeps the breaks and gives every segment its n points.
The default ladder raises the degree first and then splits (4 x 16, 4 x 32, 8 x 32, 16 x 32),
the order of Patterson et al.'s ph method: over 250 members of the robustness dispersion
(two-body, experiments/robustness_refined.py --ladder) the degree raise to 4 x 32 cured 104
of the 162 members that 4 x 16 left INACCURATE where the split to 8 x 16 cured 88, no member
needed a fourth rung (3 did on the split-only ladder 4, 8, 16, 32 x 16), the steady solve took
the same time (11.0-11.5 s against 9.7-11.7 s, alternating: bench_ladders.py) and the largest
flown miss fell from 1.8 mm to 0.7 mm; over the 1000 members, all SUCCESS (one was STALLED
before). docs/accuracy.md, "Raising the degree or splitting". The degree is raised for every
segment of a rung at once: a rung's shape is what compiles, and a segment of fewer points
padded to the rung's would cost as many.
Each rung is warm-started from the previous solution, its state polynomial and control
interpolated onto the new mesh (`interpolated_guess`). Refinement stops at the first rung whose
solution is not INACCURATE (SUCCESS, or a failure of the solver that a finer mesh does not
cure); at the last rung an INACCURATE solution stays INACCURATE.
"""

from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from ..collocation.segments import MESHES, Mesh, make_mesh
from ..status import Status

SPLIT_EXPONENT = 0.25    # a segment 10^4 times less accurate than another gets 10x the pieces
STOP = (Status.SUCCESS, Status.INVALID_INPUT, Status.SINGULAR)   # a finer mesh changes nothing


@dataclass(frozen=True)
class MeshLadder:
    """The mesh shapes of refinement, coarsest first: ((K, n), ...) segments and points per
    segment, on meshes of `scheme` ("LGR": `LGRMesh`, the default; "LG": `LGMesh`; "LGL":
    `LGLMesh`; the fuel-optimal family and minimum time by method "condensed" eliminate the
    states segment by segment, on LGR or LG segments only). The default goes from 4 x 16 =
    64 points (Mei 2010's N = 64 resolves a near-circular revolution) to 4 x 32 (the degree
    raised, module docstring), then 8 x 32 and 16 x 32 = 512 (the Newton-KKT solve's dense
    Lagrangian Hessian grows with the square of the points: 0.3 GiB at 512).
    `solve(problem, ladder)` climbs a ladder of one's own (energy-optimal, fuel-optimal and
    minimum-time transfers; each family says how it uses the rungs)."""

    rungs: tuple = ((4, 16), (4, 32), (8, 32), (16, 32))
    scheme: str = "LGR"

    def __post_init__(self):
        if self.scheme not in MESHES:
            raise ValueError(f"scheme must be one of {sorted(MESHES)}, got {self.scheme!r}")
        rungs = tuple(tuple(r) for r in self.rungs)
        if not rungs or any(len(r) != 2 or not all(isinstance(v, (int, np.integer)) and v >= 1
                                                   for v in r) for r in rungs):
            raise ValueError(f"rungs must be (segments, points per segment) pairs of positive "
                             f"integers, got {self.rungs!r}")
        object.__setattr__(self, "rungs", rungs)


DEFAULT_LADDER = MeshLadder()
"""The ladder `solve` climbs without a grid: `MeshLadder()`, the default rungs above."""


def split_breaks(breaks, segment_error, k_new: int) -> np.ndarray:
    """k_new + 1 breaks (host, NumPy) that cut the segments [breaks_i, breaks_i+1] into pieces
    in proportion to segment_error^SPLIT_EXPONENT (module docstring)."""
    b = np.asarray(breaks, np.float64)
    err = np.asarray(segment_error, np.float64)
    k = b.size - 1
    if k_new < k:
        return np.linspace(b[0], b[-1], k_new + 1)
    weight = np.where(np.isfinite(err), np.maximum(err, 1e-300), 1e300) ** SPLIT_EXPONENT
    share = (k_new - k) * weight / weight.sum()
    counts = 1 + np.floor(share).astype(int)
    extra = k_new - counts.sum()
    counts[np.argsort(-(share - np.floor(share)))[:extra]] += 1
    pieces = [np.linspace(lo, hi, c + 1)[:-1] for lo, hi, c in zip(b[:-1], b[1:], counts)]
    return np.concatenate(pieces + [b[-1:]])


def next_mesh(rung, previous, judge, scheme: str = "LGR") -> Mesh:
    """The `scheme` mesh of `rung` (K, n): uniform for the first (previous None), else the
    previous solution's breaks split by the `jaxlpm.solution.Judge`'s `refinement_error` (its
    segment errors, raised where safety constraints are violated between the nodes;
    `split_breaks`)."""
    k, n = rung
    if previous is None or not isinstance(previous.grid, Mesh):
        return make_mesh(scheme, k, n)
    return make_mesh(scheme, k, n, split_breaks(previous.grid.breaks,
                                                judge.refinement_error(previous), k))


def interpolated_guess(rows, controls, grid, mesh):
    """(state rows (n_rows', n_x), controls (n', n_u)) on `mesh` from the state rows and
    controls of a solution on `grid` (same tau in [-1, 1]): its state polynomial at the mesh's
    state rows, its control interpolant at the mesh's points."""
    support = rows[: grid.support.shape[0]]          # LG: the last row is not on it
    X = jax.vmap(lambda t: grid.interpolate_state(support, t))(mesh.support)
    U = jax.vmap(lambda t: grid.interpolate_control(controls, t))(mesh.points)
    return X, U


def refine(solve_on, guess, ladder: MeshLadder, judge):
    """Run the ladder (module docstring) for one concrete problem: solve_on(mesh, z0) -> a
    `Solution` (z0 None on the first rung), guess(solution, mesh) -> z0 for the next mesh,
    judge: a `jaxlpm.solution.Judge` (it sets INACCURATE and says where to split). Returns
    the last solution, with stats["rung"] the index of the rung it was solved on."""
    solution = None
    for index, rung in enumerate(ladder.rungs):
        mesh = next_mesh(rung, solution, judge, ladder.scheme)
        usable = solution is not None and int(solution.status) == Status.INACCURATE
        z0 = guess(solution, mesh) if usable else None
        solution = judge(solve_on(mesh, z0))
        solution = solution.replace(stats={**solution.stats, "rung": jnp.int32(index)})
        if Status(int(solution.status)) in STOP:
            break
    return solution


def first_accurate(solve_at, values):
    """(solution, value): solve_at(value) (a judged `Solution`) for each of `values` in turn
    until one is not INACCURATE, or the last: the refinement of a family whose grid is one
    number (the LQR sweep's steps, the finite burn's LGL points)."""
    for value in values:
        solution = solve_at(value)
        if int(solution.status) != Status.INACCURATE:
            break
    return solution, value

