"""Energy-optimal transfers on any model and grid by the Newton-KKT solver.

The transfer is written as an `OptimalControlProblem` in the chief's anomaly
(`jaxlpm.problems.energy_optimal`), warm-started from the linear model's KKT solution on the same
grid (Mei 2010 §3.2's law on LGL; one Newton step of the same QP on LG and LGR), and solved by
`newton_kkt` (its KKT systems by the condensed null-space solve on the nonlinear models, see
`newton_transfer`), or, with safety constraints, by the augmented Lagrangian around the same
Newton-KKT iterations. Outputs are in SI (LVLH, m, m/s, m/s^2); gradients with respect to the
problem's array leaves (e, a, duration, boundary states, J2, the constraints' numbers) come
from the implicit function theorem at the KKT point.
"""

from typing import NamedTuple

import jax
import jax.numpy as jnp

from ..problems import EnergyOptimalTransfer
from ..problems.energy_optimal import (control_scale, lvlh_state, model_state, to_solution,
                                       transfer_chief, transfer_ocp)
from ..nlp.transcription import equality, pack, state_s, state_tau, unpack
from ..collocation import Grid
from ..collocation.segments import Mesh
from ..linalg import sequential_when_batched
from ..status import Status
from .lq import kkt_law
from ..nlp.condensed_segments import condensed_linear_algebra
from ..nlp.augmented_lagrangian import ALOptions, augmented_lagrangian
from ..nlp.newton import (DenseKKT, NewtonOptions, NLPResult, first_multipliers, newton_kkt,
                          newton_step)
from ..solution import Solution


def _warm_start(problem, ocp, grid):
    """z0 from the linear model's KKT solution on the same grid, mapped node by node (same
    tau) to the model's state. On LGL grids that is Mei 2010's KKT law itself, without its
    multipliers or estimate (null-space QR, milliseconds); on LG and LGR grids and meshes the
    linear transcription's QP, solved by one Newton-KKT step (condensed where `_condenses`:
    a two-body Newton-KKT solve on 4 x 16 LGR points, without its error estimate, then takes
    9 ms instead of 26 ms with the dense LU). Also returns whether that linear problem is
    singular: its boundary states are not reachable with the thrust axes given (the law's
    status SINGULAR; on LG and LGR a step that leaves the linear constraints unmet)."""
    linear = problem.replace(model="linear", constraints=())
    if isinstance(grid, Grid) and grid.scheme == "LGL":
        law = kkt_law(linear, grid, estimate=False, multipliers=False)
        X_lvlh, U_si = law.node_states, law.node_controls
        singular = law.status == Status.SINGULAR
    else:
        ocp_lin, _, _ = transfer_ocp(linear, grid)
        n_rows = state_tau(grid).shape[0]
        zero = pack(jnp.zeros((n_rows, ocp.n_x)), jnp.zeros((grid.n, ocp.n_u)), ocp_lin.sf,
                    ocp_lin)
        z_lin = newton_step(ocp_lin, grid, zero,
                            condensed_linear_algebra if _condenses(linear, grid)
                            else DenseKKT)[0]
        # the scaled states are O(1): a QP step that misses its linear constraints by more
        # than round-off found no feasible point
        singular = ~(jnp.max(jnp.abs(equality(z_lin, ocp_lin, grid))) <= 1e-6)
        X_th, U, _ = unpack(z_lin, ocp_lin, grid)
        X_lvlh = jax.vmap(lambda x, s: lvlh_state(linear, x, s))(X_th, state_s(ocp_lin, grid))
        U_si = U * control_scale(linear)
    X = jax.vmap(lambda x, s: model_state(problem, x, s))(X_lvlh, state_s(ocp, grid))
    z0 = pack(X, U_si / control_scale(problem), ocp.sf, ocp)
    return jnp.where(singular, jnp.zeros_like(z0), z0), singular


linear_warm_start = sequential_when_batched(_warm_start)
"""`_warm_start` run member by member under vmap (`sequential_when_batched`): (z0, singular)
from (problem, ocp, grid)."""


def separation_homotopy(ocp, t):
    """The nonlinear transfer with its boundary states scaled by t (0 < t <= 1), in the same
    scaled unknowns: with L = max(|r0|, |rf|) the solver's states are x/L, so scaling both
    boundary states by t changes only the length L -> t L in the dynamics. Relative motion is
    linear to first order in L / r (Tschauner-Hempel), so small t is the linear warm start's
    own problem and t = 1 the transfer itself."""
    return ocp.replace(params={**ocp.params, "length": t * ocp.params["length"]})


LINEAR_ALGEBRA = ("auto", "condensed", "dense")


def _condenses(problem, grid):
    """Whether `CondensedSecondOrder` can solve the problem's KKT systems: every thrust axis,
    on any grid or mesh; every model."""
    return isinstance(grid, (Grid, Mesh)) and all(problem.thrust_axes)


def _condensable(problem, grid):
    """Where the transfer's Newton-KKT may take the condensed solve (`_condenses`); on the
    linear model a single grid keeps the dense solve (one Newton step of a QP) and a mesh,
    whose dense KKT matrix grows with the square of its points, takes the condensed one."""
    return _condenses(problem, grid) and (problem.model != "linear" or isinstance(grid, Mesh))


def auto_linear_algebra(problem, grid):
    """What linear_algebra="auto" picks for the transfer's Newton-KKT systems, with or without
    safety constraints: the condensed one where `_condensable`, else `DenseKKT`."""
    return condensed_linear_algebra if _condensable(problem, grid) else DenseKKT


def newton_transfer(problem, grid, options: NewtonOptions | ALOptions = NewtonOptions(),
                    warm_start: bool = True, linear_algebra: str = "auto",
                    z0=None) -> Solution:
    """Solve `problem` (any model) on `grid` (any scheme) by Newton-KKT, or with safety
    constraints (`problem.constraints`) by the augmented Lagrangian around Newton-KKT
    (`options` then an `ALOptions`; stats add outer_iterations, path_residual,
    complementarity and path_multipliers, the multipliers of g <= 0 at the points).

    linear_algebra: how each Newton-KKT system is solved: "dense" (`DenseKKT`, one LU of the
    whole KKT matrix), "condensed" (`CondensedSecondOrder`: the same step from a 3 (N - 3)-unknown
    null-space system; nonlinear models with every thrust axis; on an `LGRMesh` of 4 segments
    or more `SegmentedCondensed`, its reduced Hessian block-banded) or "auto"
    (default: "condensed" where it applies, else "dense"; with safety constraints too: the
    line search takes a step that halves the KKT residual, `jaxlpm.nlp.newton`).
    warm_start=False starts from zero states and controls (the linear model then converges
    in one Newton step: it is a QP). On the nonlinear models a failed solve is retried by
    continuation in the separation (`separation_homotopy`, from 1/64 of it to all of it);
    `iterations` then counts every Newton iteration taken. Traced invalid inputs give status
    INVALID_INPUT with zeroed outputs; a failed chief integration (model "j2") gives
    NONFINITE. z0: an initial guess in the solver's units (`refine.interpolated_guess`: a
    coarser solution of the same problem), in place of the warm start.

    The three stages (`transfer_setup`, `transfer_solve`, `transfer_solution`) are what
    `jaxlpm.solvers.energy_optimal` compiles apart, so that the first solve compiles them
    side by side (`jaxlpm.compilation.pipelined`).
    """
    check_transfer(problem, grid, options, linear_algebra)
    setup = transfer_setup(problem, grid, warm_start, z0, linear_algebra)
    return transfer_solution(setup, grid, *transfer_solve(setup, grid, options, linear_algebra))


def check_transfer(problem, grid, options, linear_algebra="auto"):
    """Raise ValueError for options or a linear algebra that `newton_transfer` cannot use."""
    constrained = bool(problem.constraints)
    if not isinstance(options, ALOptions if constrained else NewtonOptions):
        raise ValueError(f"options must be {'ALOptions' if constrained else 'NewtonOptions'} "
                         f"for a transfer {'with' if constrained else 'without'} safety "
                         f"constraints, got {type(options).__name__}")
    if linear_algebra not in LINEAR_ALGEBRA:
        raise ValueError(f"linear_algebra must be one of {LINEAR_ALGEBRA}, got "
                         f"{linear_algebra!r}")
    if linear_algebra == "condensed" and not _condensable(problem, grid):
        raise ValueError("linear_algebra='condensed' needs every thrust axis, and on the "
                         "linear model a mesh (lgr_mesh, lg_mesh, lgl_mesh); use 'dense' or "
                         "'auto'")


class TransferSetup(NamedTuple):
    """What `transfer_setup` hands the solve: the problem with invalid values replaced
    (`sanitized`) and whether it was valid, the final anomaly s_f (rad), the chief at the
    grid's and at the check mesh's state rows (`transfer_chief`), the initial guess z0 (the
    solver's scaled unknowns) with the first estimate of its equality multipliers (the linear
    algebra's `first_multipliers`), and whether the linear model found the target
    unreachable."""

    problem: EnergyOptimalTransfer
    valid: jax.Array
    s_f: jax.Array
    rows_chief: tuple
    check_chief: tuple
    z0: jax.Array
    multipliers0: jax.Array
    linear_singular: jax.Array


def _linear_algebra(problem, grid, linear_algebra):
    """The class that solves the transfer's Newton-KKT systems (`check_transfer`'s names)."""
    if linear_algebra == "auto":
        return auto_linear_algebra(problem, grid)
    return condensed_linear_algebra if linear_algebra == "condensed" else DenseKKT


def transfer_setup(problem, grid, warm_start: bool = True, z0=None,
                   linear_algebra: str = "auto") -> TransferSetup:
    """`newton_transfer`'s first stage: validity, the chief, the initial guess (z0 as
    given, else the linear model's warm start, else zeros) and its first multipliers (here,
    not in the iterations' program: that one, the largest, compiles sooner)."""
    valid = problem.validity()
    problem = problem.sanitized(valid)
    s_f, rows_chief, check_chief = transfer_chief(problem, grid)
    ocp, _, _ = transfer_ocp(problem, grid, s_f, rows_chief)
    if z0 is not None:
        z0, linear_singular = jax.lax.stop_gradient(z0), jnp.array(False)
    elif warm_start:       # an initial guess: not differentiated, member by member under vmap
        z0, linear_singular = linear_warm_start(*jax.lax.stop_gradient((problem, ocp)),
                                                     grid)
    else:
        n_rows = state_tau(grid).shape[0]
        z0 = pack(jnp.zeros((n_rows, ocp.n_x)), jnp.zeros((grid.n, ocp.n_u)), ocp.sf, ocp)
        linear_singular = jnp.array(False)
    multipliers0 = first_multipliers(ocp, grid, z0,
                                     _linear_algebra(problem, grid, linear_algebra))
    return TransferSetup(problem, valid, s_f, rows_chief, check_chief, z0, multipliers0,
                         linear_singular)


def transfer_solve(setup: TransferSetup, grid, options, linear_algebra: str = "auto"):
    """`newton_transfer`'s second stage: (`NLPResult`, the augmented Lagrangian's extra
    stats or None) of Newton-KKT, or with safety constraints the augmented Lagrangian, from
    setup.z0."""
    problem = setup.problem
    ocp, _, _ = transfer_ocp(problem, grid, setup.s_f, setup.rows_chief)
    la = _linear_algebra(problem, grid, linear_algebra)
    if not problem.constraints:
        homotopy = None if problem.model == "linear" else separation_homotopy
        return newton_kkt(ocp, grid, setup.z0, setup.multipliers0, options=options,
                          homotopy=homotopy, linear_algebra=la), None
    al = augmented_lagrangian(ocp, grid, setup.z0, setup.multipliers0, options=options,
                              linear_algebra=la)
    result = NLPResult(z=al.z, multipliers=al.multipliers, status=al.status,
                       iterations=al.inner_iterations,
                       constraint_residual=al.constraint_residual,
                       stationarity_residual=al.stationarity_residual, history=al.history,
                       regularisation=jnp.zeros((), setup.z0.dtype))
    return result, dict(outer_iterations=al.outer_iterations, path_residual=al.path_residual,
                        complementarity=al.complementarity,
                        path_multipliers=al.path_multipliers.inequality)


def transfer_solution(setup: TransferSetup, grid, result: NLPResult, extra=None) -> Solution:
    """`newton_transfer`'s last stage: the `Solution` (SI, LVLH) with its status and error
    estimate."""
    problem = setup.problem
    ocp, chief, ok = transfer_ocp(problem, grid, setup.s_f, setup.rows_chief)
    # a failed solve whose linearisation cannot reach the target with the thrust axes given
    # is reported as what it is: SINGULAR (uncontrollable), not a solver failure
    status = jnp.where(setup.linear_singular & (result.status != Status.SUCCESS),
                       Status.SINGULAR, result.status)
    status = jnp.where(setup.valid, jnp.where(ok, status, Status.NONFINITE),
                       Status.INVALID_INPUT).astype(jnp.int32)
    return to_solution(problem, ocp, grid, chief, result, status, setup.valid,
                       method="augmented-lagrangian" if problem.constraints else "newton",
                       extra=extra, check_chief=setup.check_chief)
