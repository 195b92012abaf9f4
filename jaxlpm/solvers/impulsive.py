"""Impulsive fixed-time intercept under J2 (`ImpulsiveIntercept`): Lambert + Newton shooting,
the burn time optimised by gradient; the paper's aim-point iteration.

Tan, Yan, Zhou & Tang (2011), §1: a vehicle coasting on (r0, v0) from t = 0 makes one burn at
t_b and must be at r_target at t_f, under two-body + J2 gravity.

- `lambert_candidates`: the two-body Lambert velocities for every (revolution count, branch)
  asked (prograde); the seed is the candidate of least |dv| among those the problem allows
  (`revolutions`, `branch`: given, or all M = 0..max_revolutions and both branches).
- `aim_point_iteration`: the paper's steps 1-5. As printed (step 4: L_m = L'_m, step 3: aim at
  r* - L_m) each aim point is r* minus the *latest* miss only, so once a miss is small the next
  aim returns to r* and the misses alternate: the iteration cannot converge. With
  accumulate=True the corrections add up (aim_k+1 = aim_k - L_k), the fixed-point iteration
  that converges when the J2 displacement varies slowly with the aim point.
- `shoot`: Newton's method on the post-burn velocity, r(t_f; r_b, v) = r_target, with the exact
  3x3 Jacobian by forward-mode autodiff through the diffrax coast (the paper's model (1), solved
  as a root problem), from the Lambert seed; differentiated by the implicit function theorem
  (`jaxlpm.implicit`), so |dv| is differentiable in t_b.
- A burn-time window [t_lo, t_hi]: |dv(t_b)| minimised by a safeguarded secant method on
  g = d|dv|/dt_b = 0 (g by the implicit function theorem, `burn_time_derivative`; a bracket
  g(t_lo) < 0 < g(t_hi) is kept and a secant step that leaves it is replaced by bisection;
  without a sign change it converges to the end of least |dv|).

`jaxlpm.solve(ImpulsiveIntercept(...))` (method "shooting", no grid) returns a `Solution`
(frame "inertial", trajectory `jaxlpm.solution.Impulse`):
  cost      |dv| (m/s) = delta_v; controls(t) are zero (the impulse is stats["dv"]); costates
            are not estimated (NaN)
  duration  t_f (s)
  stats     t_burn (s), dv, v_pre, v_post (3,) (m/s), r_burn (3,) (m), miss |r(t_f) -
            r_target| (m) by the solver's own coast, newton_iterations, revolutions and branch
            of the Lambert seed (0 left, 1 right), lambert_status (the seed's `Status`),
            search_iterations (secant steps; 0 for a given burn time), burn_time_gradient
            d|dv|/dt_b at t_b (m/s^2; NaN for a given burn time: not computed), the error
            estimate (`coast_accuracy`: error_position m, error_velocity m/s,
            relative_error, segment_error per coast, path_violation)
  status    SUCCESS; INACCURATE (the estimate above the tolerance); the Lambert seed's
            failure (INFEASIBLE: no allowed revolution count reaches r_target in the time;
            SINGULAR: a transfer angle of 0 or pi);
            MAX_ITERATIONS (Newton above MISS_TOL, or the secant search); NONFINITE (also a
            failed coast); INVALID_INPUT (traced bad input; outputs zeroed).
SI units: m, m/s, s, inertial frame; the coast is `jaxlpm.dynamics.propagation.propagate`.
"""

from typing import NamedTuple

import jax
import jax.numpy as jnp

from ..compilation import compiled
from ..constants import MU_EARTH
from ..dynamics.gravity import inertial_rhs
from ..dynamics.propagation import COAST_TANGENT, EPHEMERIS, propagate
from ..implicit import root
from ..orbits.lambert import lambert
from ..problems.intercept import ImpulsiveIntercept
from ..solution import Impulse, Solution, zero_invalid
from ..solution.accuracy import accuracy_stats
from ..status import Status
from .family import FamilySolver

MISS_TOL = 1e-3          # m: Newton stops at |miss| below this (the coast itself is ~mm-accurate)
NEWTON_ITERATIONS = 20
SEARCH_ITERATIONS = 30   # secant steps on d|dv|/dt_b
SEARCH_TOL = 1e-4        # s: the secant stops when its bracket is this narrow


def coast(problem: ImpulsiveIntercept, state, duration):
    """(final state, ok) of a J2 (problem.j2) coast."""
    return propagate(state, duration, problem.mu, problem.j2, problem.r_eq)


def burn_state(problem: ImpulsiveIntercept, t_burn):
    """Pre-burn state at t_burn: the initial state coasted under J2."""
    return coast(problem, problem.state0, t_burn)


def lambert_candidates(r1, r2, tof, revolutions, branches, mu=MU_EARTH):
    """Prograde Lambert solutions for every pair of the integers (scalars or 1-D arrays)
    `revolutions` (M) and `branches` (0 left, 1 right), M-major: (v1 (K, 3), M (K,),
    branch (K,), status (K,)), K = len(revolutions) len(branches) (for M = 0 the branch is
    moot)."""
    m, b = (x.ravel() for x in jnp.meshgrid(jnp.atleast_1d(revolutions),
                                            jnp.atleast_1d(branches), indexing="ij"))
    sol = jax.vmap(lambda mi, bi: lambert(r1, r2, tof, mi, bi, True, mu))(m, b)
    return sol.v1, m, b, sol.status


def lambert_seed(problem: ImpulsiveIntercept, r_burn, v_pre, tof):
    """The allowed Lambert candidate of least |v1 - v_pre| (module docstring): (v1, M,
    branch, status); where none solved, the status of the first and v1 = v_pre (a coast:
    keeps Newton finite)."""
    ms = (jnp.arange(problem.max_revolutions + 1) if problem.revolutions is None
          else problem.revolutions)
    bs = jnp.arange(2) if problem.branch is None else problem.branch
    v1, m, b, status = lambert_candidates(r_burn, problem.r_target, tof, ms, bs, problem.mu)
    ok = status == Status.SUCCESS
    k = jnp.argmin(jnp.where(ok, jnp.linalg.norm(v1 - v_pre, axis=1), jnp.inf))
    return jnp.where(ok[k], v1[k], v_pre), m[k], b[k], status[k]


def aim_point_iteration(problem: ImpulsiveIntercept, t_burn, revolutions, branch,
                        iterations: int, accumulate=False):
    """Tan 2011 steps 1-5 for `iterations` Lambert re-aims at fixed (t_burn, revolutions,
    branch).

    Returns (dv (iterations + 1, 3), miss vectors (iterations + 1, 3)): row 0 is step 1 (aim
    at r*), row k the k-th re-aim. accumulate=False is the paper as printed (aim = r* - L_m,
    L_m the latest miss); True accumulates the corrections (aim -= L_m). accumulate may be
    traced: one compiled program serves both."""
    rb_vb, _ = burn_state(problem, t_burn)
    rb, vb = rb_vb[:3], rb_vb[3:]
    tof = problem.duration - t_burn
    target = problem.r_target

    def shot(aim):
        v = lambert(rb, aim, tof, revolutions, branch, True, problem.mu).v1
        end, _ = coast(problem, jnp.concatenate([rb, v]), tof)
        return v - vb, end[:3] - target

    def step(aim, _):
        dv, miss = shot(aim)
        nxt = jnp.where(accumulate, aim - miss, target - miss)
        return nxt, (dv, miss)

    _, (dvs, misses) = jax.lax.scan(step, target, None, length=iterations + 1)
    return dvs, misses


def _miss(v, rb, tof, target, mu, j2, r_eq):
    return propagate(jnp.concatenate([rb, v]), tof, mu, j2, r_eq)[0][:3] - target


@root(_miss, has_aux=True, zero_nonfinite=True)
def _newton(v_init, rb, tof, target, mu, j2, r_eq):
    """Newton on the post-burn velocity: v <- v - J^-1 miss(v), J = d miss / dv (autodiff).
    Returns (v, (final state [r, v] (6,), iterations)).

    Each pass of one loop coasts from v with the three tangents of J (forward mode,
    `COAST_TANGENT`: the COAST integration itself), then stops at a miss below MISS_TOL or
    after NEWTON_ITERATIONS steps, else steps: the program holds one coast (issue 21)."""
    def end_and_jacobian(v):
        def position(v):
            end, _ = propagate(jnp.concatenate([rb, v]), tof, mu, j2, r_eq,
                               integrator=COAST_TANGENT)
            return end[:3], end
        return jax.jacfwd(position, has_aux=True)(v)

    def body(c):
        v, _, it, _ = c
        jac, end = end_and_jacobian(v)
        miss = jnp.linalg.norm(end[:3] - target)
        done = ~(miss > MISS_TOL) | (it >= NEWTON_ITERATIONS)          # also a non-finite miss
        v = jnp.where(done, v, v - jnp.linalg.solve(jac, end[:3] - target))
        return v, end, it + jnp.where(done, 0, 1), done

    v, end, it, _ = jax.lax.while_loop(lambda c: ~c[3], body,
                                       (v_init, jnp.zeros(6), 0, jnp.asarray(False)))
    return v, (end, it)


class Shot(NamedTuple):
    """The exact J2 intercept burning at t_burn (s): pre-burn state (6,), post-burn velocity
    (m/s), final state (6,), miss (m), Newton iterations, the Lambert seed's M, branch and
    status, and the status of the shot."""

    burn_state: jax.Array
    v_post: jax.Array
    end_state: jax.Array
    miss: jax.Array
    iterations: jax.Array
    revolutions: jax.Array
    branch: jax.Array
    lambert_status: jax.Array
    status: jax.Array

    @property
    def dv(self):
        return self.v_post - self.burn_state[3:]

    @classmethod
    def empty(cls) -> "Shot":
        """Zeros of a shot's shapes and dtypes (float64, counts and statuses int32): the
        initial carry of a loop of shots."""
        f, i = jnp.zeros, lambda: jnp.asarray(0, jnp.int32)
        return cls(f(6), f(3), f(6), f(()), i(), i(), i(), i(), i())


def shoot(problem: ImpulsiveIntercept, t_burn) -> Shot:
    """Exact J2 intercept burning at t_burn (s) by Newton shooting from the Lambert seed."""
    pre, ok_coast = burn_state(problem, t_burn)
    rb, vb = pre[:3], pre[3:]
    tof = problem.duration - t_burn
    # the seed only starts Newton, whose root is differentiated implicitly: no tangents
    v0, m, b, lam_status = lambert_seed(problem, *jax.lax.stop_gradient((rb, vb, tof)))
    v, (end, it) = _newton(v0, rb, tof, problem.r_target, problem.mu, problem.j2, problem.r_eq)
    miss = jnp.linalg.norm(end[:3] - problem.r_target)
    finite = jnp.all(jnp.isfinite(v)) & jnp.isfinite(miss) & ok_coast
    status = jnp.select([lam_status != Status.SUCCESS, ~finite, miss > MISS_TOL],
                        [lam_status, Status.NONFINITE, Status.MAX_ITERATIONS],
                        Status.SUCCESS).astype(jnp.int32)
    return Shot(pre, v, end, miss, it, m, b, lam_status, status)


def burn_time_derivative(problem: ImpulsiveIntercept, t_burn, shot: Shot):
    """g = d|dv|/dt_b (m/s^2) of the shot at t_burn, by the implicit function theorem in
    forward mode. Burning later moves the burn point along the coast (dr_b/dt_b = v_pre,
    dv_pre/dt_b = a(r_b), the J2 gravity there) and shortens the coast after it (dtof/dt_b =
    -1, dr_f/dtof = v_f); the post-burn velocity keeps r_f(r_b, v_post, tof) = r_target, so
    J_v dv_post/dt_b = -(J_r v_pre - v_f), J = dr_f/d[r_b, v] from one forward-mode coast
    with six tangents (`COAST_TANGENT`). Then g = dv . (dv_post/dt_b - a(r_b)) / |dv|.
    Reverse-mode autodiff through the shot (the diffrax coast's adjoint and the implicit
    Newton root) gave the same derivative from a program twice the size that took 20 s to
    trace (issue 21)."""
    pre = shot.burn_state

    def position(x):
        end, _ = propagate(x, problem.duration - t_burn, problem.mu, problem.j2, problem.r_eq,
                           integrator=COAST_TANGENT)
        return end[:3], end

    J, end = jax.jacfwd(position, has_aux=True)(jnp.concatenate([pre[:3], shot.v_post]))
    dv_post = -jnp.linalg.solve(J[:, 3:], J[:, :3] @ pre[3:] - end[3:])
    accel = inertial_rhs(pre, jnp.zeros(3), problem.mu, problem.j2, problem.r_eq)[3:]
    dv = shot.dv
    return jnp.dot(dv, dv_post - accel) / jnp.linalg.norm(dv)


def optimise_burn_time(problem: ImpulsiveIntercept):
    """Minimise |dv(t_b)| on the window problem.burn_time = [t_lo, t_hi] (s) by the safeguarded
    secant method on the derivative g = d|dv|/dt_b (`burn_time_derivative`; module
    docstring). Returns (t_b, the shot there, g there, secant steps, converged: the bracket
    below SEARCH_TOL).
    Not an optax loop (issue 23): this is a 1-D root of g in a bracket, which the secant
    closes superlinearly (tan2011: 9 steps from a 1000 s window to 1e-4 s) and never
    leaves; a first-order optax optimiser needs a learning rate in seconds and converges
    linearly, with no bracket to keep t_b inside the window.

    One loop evaluates g at t_lo (pass 0), t_hi (pass 1), then at the secant points, and
    carries the shot at each end of the bracket: the program holds one copy of the shot and
    its derivative (issue 21: four copies, 77 882 StableHLO lines, were 88 s of a cold
    `jaxlpm reproduce tan2011`)."""
    t_lo, t_hi = problem.burn_time[0], problem.burn_time[1]

    def cond(c):
        lo, hi, *_, it = c
        return (it < 2) | ((it < SEARCH_ITERATIONS + 2) & (hi - lo > SEARCH_TOL))

    def body(c):
        lo, hi, glo, ghi, shot_lo, shot_hi, it = c
        t = lo - glo * (hi - lo) / (ghi - glo)
        t = jnp.where((t > lo) & (t < hi), t, 0.5 * (lo + hi))
        # keep the secant from stalling at one end: never closer than 1% of the bracket
        width = hi - lo
        t = jnp.clip(t, lo + 0.01 * width, hi - 0.01 * width)
        t = jnp.select([it == 0, it == 1], [t_lo, t_hi], t)
        shot = shoot(problem, t)
        g = burn_time_derivative(problem, t, shot)
        shot = jax.tree_util.tree_map(lambda new, old: new.astype(old.dtype), shot, shot_lo)
        at_lo = jnp.where(it < 2, it == 0, g < 0)
        pick = lambda a, b: jax.tree_util.tree_map(
            lambda x, y: jnp.where(at_lo, x, y), a, b)
        lo, glo, shot_lo = pick((t, g, shot), (lo, glo, shot_lo))
        hi, ghi, shot_hi = pick((hi, ghi, shot_hi), (t, g, shot))
        return lo, hi, glo, ghi, shot_lo, shot_hi, it + 1

    shot0 = Shot.empty()
    lo, hi, glo, ghi, shot_lo, shot_hi, it = jax.lax.while_loop(
        cond, body, (t_lo, t_hi, jnp.asarray(0.0), jnp.asarray(0.0), shot0, shot0, 0))
    low = jnp.abs(glo) < jnp.abs(ghi)
    t, g = jnp.where(low, lo, hi), jnp.where(low, glo, ghi)
    shot = jax.tree_util.tree_map(lambda x, y: jnp.where(low, x, y), shot_lo, shot_hi)
    return t, shot, g, it - 2, hi - lo <= SEARCH_TOL


def coast_accuracy(problem: ImpulsiveIntercept, t_burn, shot):
    """`jaxlpm.solution.accuracy` stats (SI, inertial) of an impulsive solution, whose states
    are its coasts (`propagate`, COAST: Dopri8 at 1e-12): the same two coasts, from state0
    to t_b, the impulse, then to t_f, flown again one decade tighter (EPHEMERIS), against
    the solution's burn and end states. relative_error: per coast, the error over |r| and
    |v|. The tighter Dopri8 shares the solver's step control and rounding pattern, so where
    integrators part at ~1e-10 of |r| (millimetres over the two days of tan2011's coast) it
    under-reads the independent flight's miss by up to 5x (tests/test_tan2011.py)."""
    def leg(state, inputs):
        elapsed, kick = inputs
        end, _ = propagate(state + jnp.concatenate([jnp.zeros(3), kick]), elapsed, problem.mu,
                           problem.j2, problem.r_eq, integrator=EPHEMERIS)
        return end, end

    _, ends = jax.lax.scan(leg, problem.state0,
                           (jnp.stack([t_burn, problem.duration - t_burn]),
                            jnp.stack([jnp.zeros(3), shot.dv])))
    states = jnp.stack([shot.burn_state, shot.end_state])
    errors = ends - states
    relative = jnp.maximum(
        jnp.linalg.norm(errors[:, :3], axis=1) / jnp.linalg.norm(states[:, :3], axis=1),
        jnp.linalg.norm(errors[:, 3:], axis=1) / jnp.linalg.norm(states[:, 3:], axis=1))
    return accuracy_stats(errors, relative)


def solve_impulsive(problem: ImpulsiveIntercept) -> Solution:
    """The `Solution` of an impulsive intercept (module docstring); traceable."""
    valid = problem.validity()
    problem = problem.sanitized(valid)
    if problem.optimises_burn_time:
        t_burn, shot, gradient, searched, converged = optimise_burn_time(problem)
    else:
        t_burn = jnp.asarray(problem.burn_time, jnp.float64)
        shot, gradient = shoot(problem, t_burn), jnp.asarray(jnp.nan)
        searched, converged = jnp.asarray(0), jnp.asarray(True)
    status = jnp.where((shot.status == Status.SUCCESS) & ~converged, Status.MAX_ITERATIONS,
                       shot.status)
    status = jnp.where(valid, status, Status.INVALID_INPUT).astype(jnp.int32)
    dv = shot.dv
    trajectory = zero_invalid(valid, Impulse(
        state0=problem.state0, t_burn=t_burn, burn_state=shot.burn_state, dv=dv,
        end_state=shot.end_state, duration=problem.duration, mu=problem.mu, j2=problem.j2,
        r_eq=problem.r_eq))
    stats = zero_invalid(valid, dict(
        t_burn=t_burn, dv=dv, v_pre=shot.burn_state[3:], v_post=shot.v_post,
        r_burn=shot.burn_state[:3], miss=shot.miss, newton_iterations=shot.iterations,
        revolutions=shot.revolutions, branch=shot.branch, lambert_status=shot.lambert_status,
        search_iterations=searched, burn_time_gradient=gradient,
        **coast_accuracy(problem, t_burn, shot)))
    return Solution(problem=problem, status=status, cost=trajectory.delta_v(),
                    duration=trajectory.duration, trajectory=trajectory, stats=stats,
                    method="shooting", frame="inertial")


compiled_solve = compiled(solve_impulsive)
"""`solve_impulsive` compiled once per static structure (`jaxlpm.compilation.compiled`): what
`run` calls, and the finite burn's seed (`jaxlpm.solvers.finite_burn`)."""


def check_grid(grid, method):
    if grid is not None:
        raise ValueError(f"an impulsive intercept takes no grid (grid=None), got {grid!r:.60}")


def run(problem, grid, method, options) -> Solution:
    """Solve an `ImpulsiveIntercept` (module docstring): jit-compiled once per static
    structure (a burn time or a window; revolutions and branch given or chosen); traceable
    (vmap over problems; |dv| is differentiable for a given burn time)."""
    return compiled_solve(problem)


FAMILY = FamilySolver(problem=ImpulsiveIntercept, methods={"shooting": None}, run=run,
                      default_grid=lambda problem: None, check_grid=check_grid)
