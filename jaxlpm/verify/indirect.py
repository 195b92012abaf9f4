"""Indirect check of a minimum-time transfer (`jaxlpm.problems.min_time`, unit direction):
shooting on Pontryagin's necessary conditions, independent of any collocation grid.

In the solver's units (s = n t, state [r / L, v / (L n)], acceleration a~, `min_time_ocp`),
with costate lambda = [lambda_r, lambda_v] (Bryson & Ho 1975 §3.6; Duan & Dong 2011 eq. 6):

    x'      = A x + a~ [0; u],   lambda' = -A^T lambda,   u = -lambda_v / |lambda_v|
    H       = lambda . (A x) - a~ |lambda_v| = -1   (autonomous, free final s, cost s_f - s0)

Unknowns p = [lambda(0) (6), s_f - s0]; equations x(s_f) = x_f (6) and H(0) = -1. Newton's
method with backtracking on |R|, the Jacobian by forward-mode autodiff through the integrator
(diffrax Dopri8, rtol = atol = 1e-13: the thrust direction turns quickly where |lambda_v| is
small, which the adaptive steps resolve). Seeded from a collocated solution's costate
estimate and duration, it converges to the continuous optimum to the integrator's accuracy:
the reference for mesh studies.
"""

from dataclasses import dataclass

import jax
import jax.numpy as jnp

from .._validation import require_x64
from ..compilation import compiled
from ..dynamics import hcw_matrix
from ..dynamics.propagation import SHOOTING, solve_ode
from ..problems.min_time import min_time_ocp, state_scale
from ..status import Status


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class ShootingResult:
    """duration (s), costate0 (lambda(0), solver units), residual max |R| (solver units:
    state error over L and L n, H + 1; NaN if the guess's flow failed), iterations, status
    (`Status`)."""

    duration: jax.Array
    costate0: jax.Array
    residual: jax.Array
    iterations: jax.Array
    status: jax.Array


def _flow(params, x0, lam0, length):
    """([x, lambda](s0 + length) of the canonical system (solver units), its `solve_ode`
    status)."""
    A = hcw_matrix(1.0)

    def rhs(s, y):
        x, lam = y[:6], y[6:]
        lv = lam[3:]
        u = -lv / jnp.linalg.norm(lv)
        return jnp.concatenate([A @ x + jnp.concatenate([jnp.zeros(3), params["accel"] * u]),
                                -A.T @ lam])

    ys, status = solve_ode(rhs, jnp.concatenate([x0, lam0]), 0.0, length,
                           None, SHOOTING)
    return ys[-1], status


def _residual(p, params):
    """(`shooting_residual`, the flow's status)."""
    x0, lam0, length = params["x0"], p[:6], p[6]
    y, status = _flow(params, x0, lam0, length)
    A = hcw_matrix(1.0)
    H0 = lam0 @ (A @ x0) - params["accel"] * jnp.linalg.norm(lam0[3:])
    r = jnp.concatenate([y[:6] - params["xf"], jnp.atleast_1d(H0 + 1.0)])
    return jnp.where(status == Status.SUCCESS, r, jnp.nan), status


def shooting_residual(p, params):
    """[x(s_f) - x_f; H(0) + 1] for p = [lambda(0), s_f - s0] (solver units); NaN where the
    integration failed."""
    return _residual(p, params)[0]


def min_time_shooting(problem, costate0, duration, max_iterations: int = 30,
                      tol: float = 1e-11) -> ShootingResult:
    """Solve the necessary conditions of a unit-direction `MinimumTimeTransfer` by shooting
    from a guess of lambda(0) (solver units, e.g. `MinimumTimeSolution.costates[0]`) and the
    duration (s). jit-able; status SUCCESS when max |R| <= tol, else MAX_ITERATIONS,
    STALLED (no decrease along the Newton step) or NONFINITE. A trial point whose integration
    fails is backtracked from; if the line search ends on one, or the guess fails, the
    status is the integrator's (`solve_ode`: MAX_ITERATIONS when out of steps, else
    NONFINITE), never an exception. ValueError unless float64 is enabled. Compiled once per
    (max_iterations, tol) and kept on disk (`jaxlpm.compilation.compiled`)."""
    require_x64()
    return _shooting(problem, costate0, duration, max_iterations, tol)


@compiled(static_argnames=("max_iterations", "tol"))
def _shooting(problem, costate0, duration, max_iterations, tol):
    """`min_time_shooting`."""
    n = problem.orbit.mean_motion
    params = min_time_ocp(problem, duration).params
    jac = jax.jacfwd(shooting_residual)

    def body(s):
        p, r, k, _ = s
        step = jnp.linalg.solve(jac(p, params), -r)
        norm0 = jnp.max(jnp.abs(r))

        def ls_cond(t):
            alpha, r_new, _, j = t
            return ~(jnp.max(jnp.abs(r_new)) < (1.0 - 1e-4 * alpha) * norm0) & (j < 30)

        def ls_body(t):
            alpha, _, _, j = t
            alpha = 0.5 * alpha
            return (alpha, *_residual(p + alpha * step, params), j + 1)

        alpha, r_new, flow, _ = jax.lax.while_loop(
            ls_cond, ls_body, (1.0, *_residual(p + step, params), 0))
        better = jnp.max(jnp.abs(r_new)) < norm0
        finite = jnp.all(jnp.isfinite(r_new))
        ok = better & finite
        p_next = jnp.where(ok, p + alpha * step, p)
        r_next = jnp.where(ok, r_new, r)
        done = jnp.max(jnp.abs(r_next)) <= tol
        nonfinite = jnp.where(flow == Status.SUCCESS, Status.NONFINITE, flow)
        status = jnp.select([done, ~finite, ~better, k + 1 >= max_iterations],
                            [Status.SUCCESS, nonfinite, Status.STALLED,
                             Status.MAX_ITERATIONS], -1).astype(jnp.int32)
        return p_next, r_next, k + 1, status

    p0 = jnp.concatenate([jnp.asarray(costate0, jnp.float64), jnp.atleast_1d(duration * n)])
    r0, flow0 = _residual(p0, params)
    status0 = jnp.select([flow0 != Status.SUCCESS, jnp.max(jnp.abs(r0)) <= tol],
                         [flow0, Status.SUCCESS], -1).astype(jnp.int32)
    p, r, k, status = jax.lax.while_loop(lambda s: s[-1] == -1, body, (p0, r0, 0, status0))
    return ShootingResult(duration=p[6] / n, costate0=p[:6], residual=jnp.max(jnp.abs(r)),
                          iterations=k, status=status)


def flown_state(problem, result: ShootingResult):
    """LVLH state (m, m/s) at the end of the shooting solution's flight; NaN where the
    integration failed. ValueError unless float64 is enabled."""
    require_x64()
    params = min_time_ocp(problem, result.duration).params
    y, status = _flow(params, params["x0"], result.costate0,
                      result.duration * problem.orbit.mean_motion)
    return jnp.where(status == Status.SUCCESS, y[:6] * state_scale(problem), jnp.nan)
