"""Minimum-time transfers (`jaxlpm.problems.min_time`) by the augmented-Lagrangian solver.

Initial guess (no user guess needed): the energy-optimal QP over the same dynamics and ends
(one Newton-KKT step), at the duration T where its RMS control equals the thrust
acceleration (the control u_hat is in units of that acceleration: RMS u_hat = 1). For a double
integrator u ~ 1/T^2, so T <- T sqrt(rms u_hat) converges in a few sweeps; it starts from the rest-to-rest bang-bang time 2 sqrt(|dr| / a) + |dv| / a. The
energy-optimal control at the minimum time has RMS <= a (the minimum-time control is a
feasible competitor with RMS = a), so the guess undershoots t_f slightly; its controls,
normalised to unit length, are the initial directions.
"""

import jax
import jax.numpy as jnp

from .._validation import is_concrete, require_x64
from ..collocation import Grid
from ..problems.min_time import (check_min_time_problem, energy_ocp, min_time_ocp,
                                 state_scale)
from ..problems.transcription import (collocation_s, costates, objective, pack, state_tau,
                                      unpack)
from ..status import Status
from .augmented_lagrangian import ALOptions, augmented_lagrangian
from .condensed import CondensedSecondOrder
from .newton import newton_step
from .solution import MinimumTimeSolution

GUESS_SWEEPS = 4
MIN_POINTS = {"LGL": 4, "LG": 3, "LGR": 3}


def _energy_qp(ocp, grid, duration_nd):
    """(z, 1/2 int |u|^2 ds) of the energy-optimal QP over duration_nd."""
    eo = energy_ocp(ocp, duration_nd)
    n_rows = state_tau(grid).shape[0]
    zero = pack(jnp.zeros((n_rows, ocp.n_x)), jnp.zeros((grid.n, ocp.n_u)), eo.sf, eo)
    z, _ = newton_step(eo, grid, zero, CondensedSecondOrder)
    return z, objective(z, eo, grid), eo


def initial_guess(ocp, grid):
    """z0 for the minimum-time problem (see the module docstring)."""
    a = ocp.params["accel"]
    d = ocp.params["xf"] - ocp.params["x0"]
    T = 2.0 * jnp.sqrt(jnp.linalg.norm(d[:3]) / a) + jnp.linalg.norm(d[3:]) / a
    lo, hi = ocp.final_bounds - ocp.s0

    def sweep(T, _):
        _, J, _ = _energy_qp(ocp, grid, T)
        rms = jnp.sqrt(2.0 * J / T)
        return jnp.clip(T * jnp.sqrt(rms), lo, hi), None

    T, _ = jax.lax.scan(sweep, jnp.clip(T, lo, hi), None, length=GUESS_SWEEPS)
    z, _, eo = _energy_qp(ocp, grid, T)
    X, U, _ = unpack(z, eo, grid)
    U = U / jnp.maximum(jnp.linalg.norm(U, axis=1, keepdims=True), 1e-12)
    return pack(X, U, ocp.s0 + T, ocp)


def _min_time_transfer(problem, grid, options: ALOptions) -> MinimumTimeSolution:
    valid = problem.validity()
    problem = problem.sanitized(valid)
    ocp = min_time_ocp(problem, 0.0)
    z0 = initial_guess(jax.lax.stop_gradient(ocp), grid)   # a starting point: not differentiated
    ocp = ocp.replace(sf=z0[-1])
    result = augmented_lagrangian(ocp, grid, z0, options=options,
                                  linear_algebra=CondensedSecondOrder)
    X, U, sf = unpack(result.z, ocp, grid)
    n = problem.orbit.mean_motion
    state_s = ocp.s0 + 0.5 * (sf - ocp.s0) * (state_tau(grid) + 1.0)
    node_s = collocation_s(ocp, grid, sf)

    def keep(x):
        return jnp.where(valid, x, jnp.zeros_like(x))

    return MinimumTimeSolution(
        problem=problem, grid=grid, duration=keep((sf - ocp.s0) / n), s0=ocp.s0, sf=sf,
        node_s=node_s, node_times=keep((node_s - ocp.s0) / n),
        node_controls=keep(problem.acceleration * U), state_s=state_s,
        state_times=keep((state_s - ocp.s0) / n), states=keep(X * state_scale(problem)),
        costates=keep(costates(result.multipliers, ocp, grid)),
        multipliers=keep(result.multipliers), path_multipliers=result.path_multipliers,
        constraint_residual=result.constraint_residual, path_residual=result.path_residual,
        stationarity_residual=result.stationarity_residual,
        complementarity=result.complementarity, outer_iterations=result.outer_iterations,
        inner_iterations=result.inner_iterations, history=result.history,
        status=jnp.where(valid, result.status, Status.INVALID_INPUT).astype(jnp.int32))


_compiled = jax.jit(_min_time_transfer, static_argnames="options")


def min_time_transfer(problem, grid, options: ALOptions = ALOptions()) -> MinimumTimeSolution:
    """Solve a `MinimumTimeTransfer` on `grid` (LGL, LG or LGR) by the augmented-Lagrangian
    solver; outputs in SI (LVLH, m, m/s, m/s^2, s). jit-compiled once per grid size (and
    options) for concrete inputs; vmap- and grad-able (implicit differentiation at the KKT
    point). Concrete bad input raises ValueError; traced bad input gives status
    INVALID_INPUT and zeroed outputs. An infeasible request (a thrust too weak for t_max)
    ends with status INFEASIBLE."""
    require_x64()
    if not isinstance(grid, Grid):
        raise ValueError(f"grid must be a jaxlpm Grid (lgl(n), lg(k), lgr(k)), got {grid!r:.60}")
    check_min_time_problem(problem)
    if grid.n < MIN_POINTS[grid.scheme]:
        raise ValueError(f"minimum-time transfers need at least {MIN_POINTS[grid.scheme]} "
                         f"{grid.scheme} points, got {grid.n}")
    if is_concrete(problem, grid):
        return _compiled(problem, grid, options)
    return _min_time_transfer(problem, grid, options)
