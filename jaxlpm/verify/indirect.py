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

import diffrax
import jax
import jax.numpy as jnp

from ..dynamics import hcw_matrix
from ..problems.min_time import min_time_ocp, state_scale
from ..status import Status

RTOL = ATOL = 1e-13


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class ShootingResult:
    """duration (s), costate0 (lambda(0), solver units), residual max |R| (solver units:
    state error over L and L n, H + 1), iterations, status (`Status`)."""

    duration: jax.Array
    costate0: jax.Array
    residual: jax.Array
    iterations: jax.Array
    status: jax.Array


def _flow(params, x0, lam0, length):
    """[x, lambda](s0 + length) of the canonical system (solver units)."""
    A = hcw_matrix(1.0)

    def rhs(s, y, args):
        x, lam = y[:6], y[6:]
        lv = lam[3:]
        u = -lv / jnp.linalg.norm(lv)
        return jnp.concatenate([A @ x + jnp.concatenate([jnp.zeros(3), params["accel"] * u]),
                                -A.T @ lam])

    sol = diffrax.diffeqsolve(
        diffrax.ODETerm(rhs), diffrax.Dopri8(), 0.0, length, dt0=None,
        y0=jnp.concatenate([x0, lam0]),
        stepsize_controller=diffrax.PIDController(rtol=RTOL, atol=ATOL),
        adjoint=diffrax.ForwardMode(), max_steps=100_000)
    return sol.ys[-1]


def shooting_residual(p, params):
    """[x(s_f) - x_f; H(0) + 1] for p = [lambda(0), s_f - s0] (solver units)."""
    x0, lam0, length = params["x0"], p[:6], p[6]
    y = _flow(params, x0, lam0, length)
    A = hcw_matrix(1.0)
    H0 = lam0 @ (A @ x0) - params["accel"] * jnp.linalg.norm(lam0[3:])
    return jnp.concatenate([y[:6] - params["xf"], jnp.atleast_1d(H0 + 1.0)])


def min_time_shooting(problem, costate0, duration, max_iterations: int = 30,
                      tol: float = 1e-11) -> ShootingResult:
    """Solve the necessary conditions of a unit-direction `MinimumTimeTransfer` by shooting
    from a guess of lambda(0) (solver units, e.g. `MinimumTimeSolution.costates[0]`) and the
    duration (s). jit-able; status SUCCESS when max |R| <= tol, else MAX_ITERATIONS,
    STALLED (no decrease along the Newton step) or NONFINITE."""
    n = problem.orbit.mean_motion
    params = min_time_ocp(problem, duration).params
    jac = jax.jacfwd(shooting_residual)

    def body(s):
        p, r, k, _ = s
        step = jnp.linalg.solve(jac(p, params), -r)
        norm0 = jnp.max(jnp.abs(r))

        def ls_cond(t):
            alpha, r_new, j = t
            return ~(jnp.max(jnp.abs(r_new)) < (1.0 - 1e-4 * alpha) * norm0) & (j < 30)

        def ls_body(t):
            alpha, _, j = t
            alpha = 0.5 * alpha
            return alpha, shooting_residual(p + alpha * step, params), j + 1

        r_full = shooting_residual(p + step, params)
        alpha, r_new, _ = jax.lax.while_loop(ls_cond, ls_body, (1.0, r_full, 0))
        better = jnp.max(jnp.abs(r_new)) < norm0
        finite = jnp.all(jnp.isfinite(r_new))
        ok = better & finite
        p_next = jnp.where(ok, p + alpha * step, p)
        r_next = jnp.where(ok, r_new, r)
        done = jnp.max(jnp.abs(r_next)) <= tol
        status = jnp.select([done, ~finite, ~better, k + 1 >= max_iterations],
                            [Status.SUCCESS, Status.NONFINITE, Status.STALLED,
                             Status.MAX_ITERATIONS], -1).astype(jnp.int32)
        return p_next, r_next, k + 1, status

    p0 = jnp.concatenate([jnp.asarray(costate0, jnp.float64), jnp.atleast_1d(duration * n)])
    r0 = shooting_residual(p0, params)
    status0 = jnp.where(jnp.max(jnp.abs(r0)) <= tol, Status.SUCCESS, -1).astype(jnp.int32)
    p, r, k, status = jax.lax.while_loop(lambda s: s[-1] == -1, body, (p0, r0, 0, status0))
    return ShootingResult(duration=p[6] / n, costate0=p[:6], residual=jnp.max(jnp.abs(r)),
                          iterations=k, status=status)


def flown_state(problem, result: ShootingResult):
    """LVLH state (m, m/s) at the end of the shooting solution's flight."""
    params = min_time_ocp(problem, result.duration).params
    y = _flow(params, params["x0"], result.costate0, result.duration * problem.orbit.mean_motion)
    return y[:6] * state_scale(problem)
