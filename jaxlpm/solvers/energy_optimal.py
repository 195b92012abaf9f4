"""Energy-optimal transfers (`EnergyOptimalTransfer`): which method solves which model and grid.

"kkt" (Mei 2010 §3.2, collocated state equations) and "stm" (§3.1, Gramian of the
Yamanaka-Ankersen STM) are the closed-form laws of the linear (Tschauner-Hempel) model on LGL
grids (`jaxlpm.solvers.lq`); "newton" is the Newton-KKT solver of the NLP engine on any model
("linear", "two-body", "j2") and grid (LGL, LG, LGR) (`jaxlpm.solvers.transfer`);
"augmented-lagrangian" the same Newton-KKT iterations inside the augmented Lagrangian, for
transfers with safety constraints (`jaxlpm.problems.safety`), the only method they take. Each
is jit-compiled once per (method, grid, options) (Newton-KKT and the augmented Lagrangian as
three programs, compiled side by side: `jaxlpm.compilation.pipelined`), except that a
concrete solve by a law runs on its grid padded to 129 points (`jaxlpm.collocation.padded`:
one program per law for every grid up to lgl(129), the solution gathered back onto its own
grid; traced, under jit or vmap, it runs on the grid itself). Default:
"augmented-lagrangian" with constraints, else "kkt" for the linear model on an LGL grid,
"newton" otherwise; default grid lgl(65) (Mei 2010's N = 64).

`Solution.stats`: node_f / node_s (the independent variable at the collocation points, rad),
cost_true_anomaly (k^2 cost, m^2/s^4: Mei 2010 eq. 8's normalisation), multipliers,
constraint_residual, stationarity_residual, the error estimate between the nodes
(error_position m, error_velocity m/s, relative_error, segment_error, path_violation:
`jaxlpm.solution.accuracy`), and per method: rcond, node_states_th, costates_th (the laws),
iterations, history, costates_scaled (Newton-KKT), rung (the refinement rung, `solve` without
a grid); with safety constraints also constraint_violation, violation_position,
violation_velocity, segment_violation (the dense check in SI, `safety_stats`),
outer_iterations, path_residual,
complementarity and path_multipliers.

`solve(problem)` without a grid, for a concrete problem, refines the mesh (`refine_transfer`:
Newton-KKT on the `MeshLadder` of mesh shapes, `LGRMesh` by default, until the estimate meets
the tolerance; `solve(problem, ladder)` climbs a ladder of LG or LGL meshes too);
traced (under jit/vmap) it solves on the default grid and reports the estimate and status
(batches refine with `jaxlpm.batch.refine.refine_batch`).
"""

import dataclasses

import jax.numpy as jnp
import numpy as np

from .._validation import is_concrete
from ..compilation import compiled, pipelined
from ..collocation import Grid, lgl
from ..collocation.padded import pad_grid
from ..collocation.segments import Mesh
from ..nlp.augmented_lagrangian import ALOptions
from ..nlp.newton import NewtonOptions
from ..problems import EnergyOptimalTransfer
from .family import FamilySolver
from .lq import kkt_law, stm_law, unpadded
from ..problems.energy_optimal import scaled_rows
from .refine import DEFAULT_LADDER, MeshLadder, interpolated_guess, refine
from .transfer import check_transfer, transfer_setup, transfer_solution, transfer_solve

DEFAULT_POINTS = 65            # Mei 2010's N = 64
MIN_LAW_POINTS = 4   # the KKT law needs interior nodes beyond the 2 velocity conditions per axis
MIN_NEWTON_POINTS = {"LGL": 4, "LG": 3, "LGR": 3}
_LAWS = {"stm": compiled(stm_law),
         "kkt": compiled(kkt_law, static_argnames=("estimate", "multipliers"))}


_setup = compiled(transfer_setup, static_argnames=("warm_start", "linear_algebra"))
_solve = compiled(transfer_solve, static_argnames=("options", "linear_algebra"))
_solution = compiled(transfer_solution)


def _newton(problem, grid, options, z0=None):
    """`newton_transfer` (from z0, else the warm start) as its three stages, each compiled
    apart: the first solve of a signature compiles them side by side (`pipelined`)."""
    check_transfer(problem, grid, options)

    def run():
        setup = _setup(problem, grid, z0=z0)
        return _solution(setup, grid, *_solve(setup, grid, options))

    return pipelined(run, _setup, problem, grid, z0=z0)


@compiled
def _guess(solution, mesh):
    """z0 on `mesh` from a Newton-KKT solution on a coarser mesh (`interpolated_guess` of its
    scaled state rows and controls)."""
    X, U = interpolated_guess(*scaled_rows(solution), solution.grid, mesh)
    return jnp.concatenate([X.reshape(-1), U.reshape(-1)])


def rung_options(options, segments: int):
    """The options of a rung of K segments: the defects are written in the mesh's tau on
    [-1, 1], so a segment K times shorter than the whole has a differentiation matrix K times
    larger; the same accuracy of its local defects (and the same round-off floor) is K times
    the residual. `ALOptions`: the same for their inner Newton-KKT options."""
    if isinstance(options, ALOptions):
        return dataclasses.replace(options, inner=rung_options(options.inner, segments))
    return dataclasses.replace(options, tol_feasibility=options.tol_feasibility * segments)


def refine_transfer(problem, options, judge, ladder: MeshLadder = DEFAULT_LADDER):
    """Newton-KKT on the `MeshLadder` until the estimate meets the tolerance
    (`jaxlpm.solvers.refine`): every model; the first rung from the linear model's warm start,
    each next one from the previous solution; with safety constraints by the augmented
    Lagrangian (`ALOptions`)."""
    if options is None:
        options = ALOptions() if problem.constraints else NewtonOptions()

    def solve_on(mesh, z0):
        rung = rung_options(options, mesh.n_segments)
        return _newton(problem, mesh, rung, z0)

    return refine(solve_on, _guess, ladder, judge)


def default_method(problem, grid):
    """The augmented Lagrangian with safety constraints, else the KKT law for the linear
    model on an LGL grid, Newton-KKT otherwise."""
    if problem.constraints:
        return "augmented-lagrangian"
    return ("kkt" if problem.model == "linear" and isinstance(grid, Grid)
            and grid.scheme == "LGL" else "newton")


def refine_method(problem, ladder=None):
    """The method of mesh refinement (on any `ladder`): Newton-KKT, inside the augmented
    Lagrangian where the transfer has safety constraints."""
    return "augmented-lagrangian" if problem.constraints else "newton"


def check_grid(grid, method):
    if method == "augmented-lagrangian":
        method = "newton"                     # the same transcription and Newton-KKT
    if isinstance(grid, Mesh) and method == "newton":
        if grid.segment.n < MIN_NEWTON_POINTS[grid.scheme]:
            raise ValueError(f"the Newton-KKT solver needs at least "
                             f"{MIN_NEWTON_POINTS[grid.scheme]} {grid.scheme} points per "
                             f"segment, got {grid.segment.n}")
        return
    if not isinstance(grid, Grid):
        raise ValueError(f"grid must be a jaxlpm Grid (lgl(n), lg(n), lgr(n): n points) or, "
                         f"for method 'newton', a Mesh (lgr_mesh, lg_mesh, lgl_mesh(k, n)), "
                         f"got {grid!r:.60}")
    if method == "newton":
        if grid.n < MIN_NEWTON_POINTS[grid.scheme]:
            raise ValueError(f"the Newton-KKT solver needs at least "
                             f"{MIN_NEWTON_POINTS[grid.scheme]} {grid.scheme} points, got "
                             f"{grid.n}")
    elif grid.scheme != "LGL":
        raise ValueError(f"the LQ laws are defined on LGL grids (lgl(n)), got {grid.scheme}")
    elif grid.n < MIN_LAW_POINTS:
        raise ValueError(f"the LQ laws need at least {MIN_LAW_POINTS} LGL points, got "
                         f"{grid.n}")


def run(problem, grid, method, options):
    """The method's compiled solver (traced input too: under an outer jit it inlines, under
    an eager vmap or grad it compiles one program instead of dispatching op by op)."""
    if bool(problem.constraints) != (method == "augmented-lagrangian"):
        raise ValueError(
            "a transfer with safety constraints is solved by method 'augmented-lagrangian' "
            f"(options ALOptions), got {method!r}" if problem.constraints else
            "method 'augmented-lagrangian' is for transfers with safety constraints "
            "(EnergyOptimalTransfer(..., constraints=[...])); this one has none: use 'newton'")
    if method in ("newton", "augmented-lagrangian"):
        return _newton(problem, grid, options)
    if problem.model != "linear":
        raise ValueError(f"the {method!r} law is linear: model must be 'linear', got "
                         f"{problem.model!r} (use method='newton' for nonlinear models)")
    if is_concrete(problem) and np.ndim(problem.duration) == 0:
        # one solve: on the grid padded to its capacity, one program for every grid up to it
        return unpadded(_LAWS[method](problem, pad_grid(grid.n)), grid)
    return _LAWS[method](problem, grid)


FAMILY = FamilySolver(problem=EnergyOptimalTransfer,
                      methods={"kkt": None, "stm": None, "newton": NewtonOptions,
                               "augmented-lagrangian": ALOptions}, run=run,
                      default_grid=lambda problem: lgl(DEFAULT_POINTS), check_grid=check_grid,
                      default_method=default_method, refine=refine_transfer,
                      refine_method=refine_method, ladders=True)
