"""Impulsive fixed-time intercept under J2: Lambert + aim-point iteration + Newton shooting.

Tan, Yan, Zhou & Tang (2011), §1: a vehicle coasting on (r0, v0) from t = 0 makes one burn at
t_b and must be at r_target at t_f, under two-body + J2 gravity.

- `lambert_candidates` / `best_lambert`: the two-body Lambert velocities for every revolution
  count 0..max_revs and both branches (prograde), the one of least |dv| chosen.
- `aim_point_iteration`: the paper's steps 1-5. As printed (step 4: L_m = L'_m, step 3: aim at
  r* - L_m) each aim point is r* minus the *latest* miss only, so once a miss is small the next
  aim returns to r* and the misses alternate: the iteration cannot converge. With
  accumulate=True the corrections add up (aim_k+1 = aim_k - L_k), the fixed-point iteration
  that converges when the J2 displacement varies slowly with the aim point.
- `shoot`: Newton's method on the post-burn velocity, r(t_f; r_b, v) = r_target, with the exact
  3x3 Jacobian by reverse-mode autodiff through the diffrax coast (the paper's model (1), solved
  as a root problem); differentiated by the implicit function theorem (`jaxlpm.implicit`).
- `impulse`: |dv| of the shot solution as a function of t_b, differentiable, for burn-time
  optimisation by gradient; `optimise_burn_time` does it by a safeguarded secant method on
  d|dv|/dt_b = 0.

SI units: m, m/s, s, inertial frame; the coast is `jaxlpm.dynamics.propagation.propagate`.
"""

from dataclasses import dataclass, field

import jax
import jax.numpy as jnp

from ..constants import J2_EARTH, MU_EARTH, R_EARTH
from ..dynamics.propagation import propagate
from ..implicit import root
from ..orbits.lambert import lambert
from ..status import Status

MISS_TOL = 1e-3          # m: Newton stops at |miss| below this (the coast itself is ~mm-accurate)
NEWTON_ITERATIONS = 20


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class InterceptProblem:
    """Initial inertial state (m, m/s) at t = 0, intercept time t_f (s) and point (m), gravity."""

    state0: jax.Array
    t_f: jax.Array
    r_target: jax.Array
    mu: jax.Array = field(default=MU_EARTH)
    j2: jax.Array = field(default=J2_EARTH)
    r_eq: jax.Array = field(default=R_EARTH)


def coast(problem: InterceptProblem, state, duration):
    """(final state, ok) of a J2 (problem.j2) coast."""
    return propagate(state, duration, problem.mu, problem.j2, problem.r_eq)


def burn_state(problem: InterceptProblem, t_burn):
    """Pre-burn state at t_burn: the initial state coasted under J2."""
    return coast(problem, problem.state0, t_burn)


def lambert_candidates(r1, r2, tof, max_revs: int, mu=MU_EARTH):
    """Prograde Lambert solutions for M = 0..max_revs, both branches: (v1 (K, 3), revs (K,),
    branch (K,), status (K,)), K = 2 (max_revs + 1) (M = 0 appears twice: its branch is moot)."""
    revs = jnp.repeat(jnp.arange(max_revs + 1), 2)
    branch = jnp.tile(jnp.arange(2), max_revs + 1)
    sol = jax.vmap(lambda m, b: lambert(r1, r2, tof, m, b, True, mu))(revs, branch)
    return sol.v1, revs, branch, sol.status


def best_lambert(r1, v_pre, r2, tof, max_revs: int, mu=MU_EARTH):
    """The candidate of least |v1 - v_pre|: (v1, revs, branch, status). Status INFEASIBLE when
    no candidate solved."""
    v1, revs, branch, status = lambert_candidates(r1, r2, tof, max_revs, mu)
    ok = status == Status.SUCCESS
    dv = jnp.where(ok, jnp.linalg.norm(v1 - v_pre, axis=1), jnp.inf)
    k = jnp.argmin(dv)
    st = jnp.where(jnp.any(ok), Status.SUCCESS, Status.INFEASIBLE).astype(jnp.int32)
    return v1[k], revs[k], branch[k], st


def aim_point_iteration(problem: InterceptProblem, t_burn, revs, branch, iterations: int,
                        accumulate: bool = False):
    """Tan 2011 steps 1-5 for `iterations` Lambert re-aims at fixed (t_burn, revs, branch).

    Returns (dv (iterations + 1, 3), miss vectors (iterations + 1, 3)): row 0 is step 1 (aim
    at r*), row k the k-th re-aim. accumulate=False is the paper as printed (aim = r* - L_m,
    L_m the latest miss); True accumulates the corrections (aim -= L_m)."""
    rb_vb, _ = burn_state(problem, t_burn)
    rb, vb = rb_vb[:3], rb_vb[3:]
    tof = problem.t_f - t_burn
    target = problem.r_target

    def shot(aim):
        v = lambert(rb, aim, tof, revs, branch, True, problem.mu).v1
        end, _ = coast(problem, jnp.concatenate([rb, v]), tof)
        return v - vb, end[:3] - target

    def step(aim, _):
        dv, miss = shot(aim)
        nxt = jnp.where(accumulate, aim - miss, target - miss)
        return nxt, (dv, miss)

    _, (dvs, misses) = jax.lax.scan(step, target, None, length=iterations + 1)
    return dvs, misses


def _miss(v, rb, tof, target, mu, j2, r_eq):
    end, _ = propagate(jnp.concatenate([rb, v]), tof, mu, j2, r_eq)
    return end[:3] - target


@root(_miss, has_aux=True, zero_nonfinite=True)
def _newton(v_init, rb, tof, target, mu, j2, r_eq):
    """Newton on the post-burn velocity: v <- v - J^-1 miss(v), J = d miss / dv (autodiff)."""
    f = lambda v: _miss(v, rb, tof, target, mu, j2, r_eq)

    def cond(c):
        _, miss, it = c
        return (it < NEWTON_ITERATIONS) & (jnp.linalg.norm(miss) > MISS_TOL)

    def body(c):
        v, miss, it = c
        jac = jax.jacrev(f)(v)
        v = v - jnp.linalg.solve(jac, miss)
        return v, f(v), it + 1

    v, miss, it = jax.lax.while_loop(cond, body, (v_init, f(v_init), 0))
    return v, (jnp.linalg.norm(miss), it)


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class ImpulsiveSolution:
    """Burn at t_burn (s): position r_burn (m), pre-burn velocity v_pre and post-burn v_post
    (m/s), dv = v_post - v_pre (m/s), the J2 coast's miss |r(t_f) - r_target| (m), Newton
    iterations and status (SUCCESS, MAX_ITERATIONS, NONFINITE, or INFEASIBLE when no Lambert
    solution seeds it)."""

    t_burn: jax.Array
    r_burn: jax.Array
    v_pre: jax.Array
    v_post: jax.Array
    dv: jax.Array
    miss: jax.Array
    iterations: jax.Array
    status: jax.Array


def shoot(problem: InterceptProblem, t_burn, revs, branch, v_init=None):
    """Exact J2 intercept by Newton shooting from the two-body Lambert velocity (or v_init)."""
    pre, ok_coast = burn_state(problem, t_burn)
    rb, vb = pre[:3], pre[3:]
    tof = problem.t_f - t_burn
    lam = lambert(rb, problem.r_target, tof, revs, branch, True, problem.mu)
    v0 = lam.v1 if v_init is None else v_init
    v, (miss, it) = _newton(v0, rb, tof, problem.r_target, problem.mu, problem.j2, problem.r_eq)
    finite = jnp.all(jnp.isfinite(v)) & jnp.isfinite(miss) & ok_coast
    status = jnp.select(
        [(v_init is None) & (lam.status != Status.SUCCESS), ~finite, miss > MISS_TOL],
        [Status.INFEASIBLE, Status.NONFINITE, Status.MAX_ITERATIONS],
        Status.SUCCESS).astype(jnp.int32)
    return ImpulsiveSolution(t_burn=jnp.asarray(t_burn, jnp.float64), r_burn=rb, v_pre=vb,
                             v_post=v, dv=v - vb, miss=miss, iterations=it, status=status)


def impulse(problem: InterceptProblem, t_burn, revs, branch):
    """|dv| (m/s) of the exact J2 intercept burning at t_burn: differentiable in t_burn."""
    return jnp.linalg.norm(shoot(problem, t_burn, revs, branch).dv)


def optimise_burn_time(problem: InterceptProblem, t_lo, t_hi, revs, branch,
                       iterations: int = 30, t_tol: float = 1e-4):
    """Minimise |dv(t_b)| on [t_lo, t_hi] (s) by a safeguarded secant method on the autodiff
    derivative g = d|dv|/dt_b: a bracket with g(t_lo) < 0 < g(t_hi) is kept and a secant step
    that leaves it is replaced by bisection. Returns (t_b, |dv|, g, iterations)."""
    grad = jax.value_and_grad(lambda t: impulse(problem, t, revs, branch))

    def cond(c):
        lo, hi, *_ , it = c
        return (it < iterations) & (hi - lo > t_tol)

    def body(c):
        lo, hi, glo, ghi, it = c
        t = lo - glo * (hi - lo) / (ghi - glo)
        t = jnp.where((t > lo) & (t < hi), t, 0.5 * (lo + hi))
        # keep the secant from stalling at one end: never closer than 1% of the bracket
        width = hi - lo
        t = jnp.clip(t, lo + 0.01 * width, hi - 0.01 * width)
        _, g = grad(t)
        lo, glo = jnp.where(g < 0, t, lo), jnp.where(g < 0, g, glo)
        hi, ghi = jnp.where(g < 0, hi, t), jnp.where(g < 0, ghi, g)
        return lo, hi, glo, ghi, it + 1

    _, glo = grad(t_lo)
    _, ghi = grad(t_hi)
    lo, hi, glo, ghi, it = jax.lax.while_loop(
        cond, body, (jnp.asarray(t_lo, jnp.float64), jnp.asarray(t_hi, jnp.float64), glo, ghi, 0))
    t = jnp.where(jnp.abs(glo) < jnp.abs(ghi), lo, hi)
    value, g = grad(t)
    return t, value, g, it
