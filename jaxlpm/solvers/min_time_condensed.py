"""Minimum-time transfers (`jaxlpm.problems.min_time`) on the linear (Tschauner-Hempel, HCW at
e = 0), two-body and J2 models: method "condensed", the reachable set of the condensed LGR or LG
transcription (`jaxlpm.problems.fuel_optimal.condensed_mesh`, `jaxlpm.nlp.reachable`).

For a duration T the transcription of the fuel-optimal family (the energy-optimal transfer's
scaled states and anomaly, a segmented LGR mesh with breaks as fractions of [s0, s_f(T)], the
dynamics linearised at the collocation points) gives the final state as
x_K = Phi x0 + o + sum_i E_i v_i, |v_i| <= 1 (v = u / u_max). The transfer is possible in T
iff F*(T) = min_{p . d = 1} sum_i |E_i^T p| >= 1 (d = x_f - Phi x0 - o; `reachable`), and the
minimum time solves F*(T) = 1: Newton on log F*(T) against log T, its derivative at fixed p*
(the envelope theorem, differentiated through the transcription), from the rest-to-rest
bang-bang time 2 sqrt(|dr| / a) + |dv| / a, inside [0, t_max]. At T* the engine fires at full
thrust along the primers E_i^T p* (the minimiser's directions reach d exactly), the constant-
thrust, free-direction optimum of Duan & Dong 2011. On the nonlinear models the dynamics are
relinearised about each solution's states until they settle, as for the fuel-optimal family.

Costates: the sensitivity of T* to the state, dT*/dd = p* / (dF*/dT) (F* = 1), carried back
along the transcription by its discrete adjoint (`CondensedMesh.costates`).

`min_time_shooting(problem)`: the same equation on the exact Yamanaka-Ankersen flow of the
linear model with Gauss quadrature (no collocation): the shooting cross-check.
"""

from dataclasses import dataclass, replace

import jax
import jax.numpy as jnp
import numpy as np

from .._validation import is_concrete, require_x64
from ..collocation.segments import as_segmented, segmented_lgr, segmented_mesh, uniform_breaks
from ..compilation import compiled
from ..nlp.accuracy import unit_direction
from ..nlp.reachable import primer_directions, support, support_minimiser
from ..problems.energy_optimal import collocation_accuracy
from ..problems.fuel_optimal import FuelOptimalTransfer, collocated_trajectory, transcribe
from ..problems.min_time import MinimumTimeTransfer
from ..solution import Solution, zero_invalid
from ..status import Status
from .fuel_optimal import check_ladder, check_segmented, exact_linear_nlp, panel_quadrature
from .refine import MeshLadder


@dataclass(frozen=True)
class CondensedOptions:
    """Static settings of method "condensed" (hashable: one compiled solver per set).

    duration_iterations  Newton steps on log T at most (a handful where log F* is smooth)
    duration_tol         relative step in T at which they stop
    max_linearisations   relinearisations of nonlinear dynamics at most
    linearisation_tol    they stop when the collocated states move by at most this (solver
                         units)
    """

    duration_iterations: int = 50
    duration_tol: float = 1e-12
    max_linearisations: int = 12
    linearisation_tol: float = 1e-8


def _fuel_twin(problem: MinimumTimeTransfer, duration) -> FuelOptimalTransfer:
    """The bounded-thrust transfer of `duration` with the same engine and model, whose
    transcription this method shares (its Isp is unused)."""
    return FuelOptimalTransfer(problem.orbit, problem.x0, problem.xf, duration,
                               problem.thrust, problem.mass, jnp.ones_like(problem.mass),
                               model=problem.model, j2=problem.j2, r_eq=problem.r_eq)


def _condensed(problem, mesh, T, ref):
    """(transcription, FuelNLP) at duration T linearised at the collocation states ref."""
    tr = transcribe(_fuel_twin(problem, T), mesh)
    return tr, tr.linearised(ref)


def _ones(nlp):
    return jnp.ones(nlp.E.shape[0], nlp.E.dtype)


def _log_margin(problem, mesh, T, ref, p):
    """log(h_T(p) / p . d(T)): 0 where the unit-bounded control just reaches the target."""
    _, nlp = _condensed(problem, mesh, T, ref)
    return jnp.log(support(nlp.E, _ones(nlp), p) / (p @ nlp.d))


SCAN_RATIO = 1.25     # the fallback's scan for the first reachable duration: T x 1.25 a step
SCAN_STEPS = 64       # its steps at most, each way (1.25^64 ~ 1.6e6)


NEWTON, HALVE, SCAN, BRACKET, DONE = range(5)     # the phases of `_duration`'s loop


def _duration(problem, mesh, ref, T0, hi, options):
    """(T*, p*, d log F*/d log T at T*, converged): Newton on log F*(T) = 0 in log T, clipped
    to (0, hi] (module docstring). Where Newton does not converge (the constant-thrust
    reachable sets are not nested in time, so log F* need not be monotone), the fallback
    brackets the first reachable duration: from T0 / 4, halved while the target is
    reachable, then T grown by `SCAN_RATIO` until it is, and the crossing in that last step
    found by Newton safeguarded by bisection (a Newton step that leaves the bracket bisects
    it). A reachable excursion shorter than one scan step can be missed. One loop runs the
    phases, one evaluation of log F* an iteration (one copy of it in the program); where
    Newton converges it evaluates exactly what Newton alone would."""
    log_hi, ratio = jnp.log(hi), jnp.log(SCAN_RATIO)

    def at(u):
        """(p*, log F*, its derivative in u at fixed p*) at T = e^u."""
        _, nlp = _condensed(problem, mesh, jnp.exp(u), ref)
        p = jax.lax.stop_gradient(support_minimiser(nlp.E, _ones(nlp), nlp.d))
        margin = lambda v: _log_margin(problem, mesh, jnp.exp(v), ref, p)   # noqa: E731
        return (p, *jax.value_and_grad(margin)(u))

    def bracket_step(a, b, x, g, dg):
        """The bracket [a, b] (log F* < 0 at a, >= 0 at b) updated with x and its next point:
        Newton where it stays inside, else the midpoint."""
        a, b = jnp.where(g < 0.0, x, a), jnp.where(g < 0.0, b, x)
        newton = x - g / jnp.where(dg > 0.0, dg, 1.0)
        x_new = jnp.where((dg > 0.0) & (newton > a) & (newton < b), newton, 0.5 * (a + b))
        return a, b, x_new, x_new - x

    def body(s):
        phase, c, a, b, step, k = s[:6]
        p, g, dg = at(c)
        tol_met = jnp.abs(step) <= options.duration_tol
        out_of_steps = k >= options.duration_iterations
        # Newton; where log F* is not increasing in log T, the step of F* ~ T^2
        n_step = jnp.where(dg > 0, -g / dg, -0.5 * g)
        n_next = jnp.minimum(c + n_step, log_hi)
        n_next = jnp.where(jnp.isfinite(n_next), n_next, c)
        newton_ends = tol_met | out_of_steps
        newton_ok = newton_ends & tol_met & (jnp.abs(g) <= 1e-9)
        # halving: on while reachable
        halve_on = (g >= 0.0) & (k < SCAN_STEPS)
        # scan: on while short of the target
        scan_on = (g < 0.0) & (c < log_hi) & (k < SCAN_STEPS)
        ba, bb, bx, bstep = bracket_step(a, jnp.where(phase == SCAN, c, b), c, g, dg)
        bracket_ends = (phase == BRACKET) & (tol_met | out_of_steps)
        nxt = jnp.select(
            [phase == NEWTON, phase == HALVE, phase == SCAN],
            [jnp.where(newton_ends, jnp.where(newton_ok, DONE, HALVE), NEWTON),
             jnp.where(halve_on, HALVE, SCAN), jnp.where(scan_on, SCAN, BRACKET)],
            jnp.where(bracket_ends, DONE, BRACKET))
        c_next = jnp.select(
            [phase == NEWTON, phase == HALVE, phase == SCAN],
            [jnp.where(newton_ends, jnp.where(newton_ok, c, u_start), n_next),
             jnp.where(halve_on, c - jnp.log(2.0),
                       jnp.where(g < 0.0, jnp.minimum(c + ratio, log_hi), c)),
             jnp.where(scan_on, jnp.minimum(c + ratio, log_hi), bx)],
            jnp.where(bracket_ends, c, bx))
        a_next = jnp.select([phase == HALVE, phase == SCAN],
                            [c, jnp.where(scan_on, c, ba)], jnp.where(bracket_ends, a, ba))
        b_next = jnp.where(phase == SCAN, jnp.where(scan_on, b, bb),
                           jnp.where((phase == BRACKET) & ~bracket_ends, bb, b))
        step_next = jnp.select(
            [phase == NEWTON, phase == HALVE, phase == SCAN],
            [jnp.where(newton_ends, step, c_next - c), step, jnp.where(scan_on, step, bstep)],
            jnp.where(bracket_ends, step, bstep))
        k_next = jnp.where(nxt == phase, k + 1, jnp.where(nxt == BRACKET, 1, 0))
        return nxt, c_next, a_next, b_next, step_next, k_next, p, g, dg

    u0 = jnp.minimum(jnp.log(T0), log_hi)
    u_start = u0 - jnp.log(4.0)              # the fallback's first duration
    inf = jnp.asarray(jnp.inf, u0.dtype)
    zero = 0.0 * u0
    p0 = jnp.zeros(ref.shape[-1], u0.dtype)
    s = jax.lax.while_loop(lambda s: s[0] != DONE, body,
                           (jnp.asarray(NEWTON), u0, zero, zero, inf, jnp.asarray(0),
                            p0, zero, zero))
    _, u, _, _, step, _, p, g, dg = s
    return jnp.exp(u), p, dg, (jnp.abs(g) <= 1e-9) & (jnp.abs(step) <= options.duration_tol)


def rest_to_rest(problem):
    """2 sqrt(|dr| / a) + |dv| / a (s): the rest-to-rest bang-bang time plus the velocity
    change at full thrust, a first duration."""
    d = problem.xf - problem.x0
    a = problem.acceleration
    return 2.0 * jnp.sqrt(jnp.linalg.norm(d[:3]) / a) + jnp.linalg.norm(d[3:]) / a


def _solve(problem, mesh, options):
    """(T*, p*, dlogF/dlogT, reference states, converged, linearisations, change)."""
    hi = jnp.where(jnp.isfinite(problem.bounds[1]), problem.bounds[1],
                   1e3 * problem.orbit.period)
    ref = jnp.zeros((mesh.n_points, 6), problem.x0.dtype)

    def run_at(ref, T0):
        T, p, dg, ok = _duration(problem, mesh, ref, T0, hi, options)
        _, nlp = _condensed(problem, mesh, T, ref)
        U = nlp.umax * primer_directions(nlp.E, p)
        X = nlp.cond.states(nlp.x0, U.reshape(mesh.n_segments, mesh.grid.n, 3))
        return T, p, dg, ok, nlp.cond.collocation_rows(X)

    T, p, dg, ok, X = run_at(ref, rest_to_rest(problem))
    change = jnp.max(jnp.abs(X - ref))
    if problem.model == "linear":
        return T, p, dg, ref, ok, jnp.asarray(1), jnp.zeros_like(change)

    def going(s):
        return s[3] & (s[6] < options.max_linearisations) & (s[7] > options.linearisation_tol)

    def body(s):
        T, _, _, _, _, X, k, _ = s
        T_new, p, dg, ok, X_new = run_at(X, T)
        return T_new, p, dg, ok, X, X_new, k + 1, jnp.max(jnp.abs(X_new - X))

    T, p, dg, ok, ref, _, k, change = jax.lax.while_loop(
        going, body, (T, p, dg, ok, ref, X, jnp.asarray(1), change))
    return T, p, dg, ref, ok, k, change


def _min_time_condensed(problem, mesh, options):
    valid = problem.validity() & (problem.bounds[0] == 0.0)
    requested = problem
    problem = jax.lax.stop_gradient(problem.sanitized(valid))
    T, p, dg, ref, ok, runs, change = _solve(problem, mesh, options)
    tr, nlp = _condensed(problem, mesh, T, ref)
    K, n = mesh.n_segments, mesh.grid.n
    U = nlp.umax * primer_directions(nlp.E, p)
    rows = nlp.cond.mesh_rows(nlp.cond.states(nlp.x0, U.reshape(K, n, 3)))
    energy = tr.problem.energy_problem()
    hi = problem.bounds[1]
    reached = jnp.max(jnp.abs(jnp.einsum("iab,ib->a", nlp.E, U / nlp.umax) - nlp.d))
    status = jnp.select(
        [~valid, ~tr.ok, (T >= hi * (1.0 - 1e-12)) & (reached > 1e-8),
         ok & (change <= options.linearisation_tol)],
        [Status.INVALID_INPUT, Status.NONFINITE, Status.INFEASIBLE, Status.SUCCESS],
        Status.MAX_ITERATIONS).astype(jnp.int32)
    # dT*/dd = p* / (dF*/dT) at F* = 1, F* = exp(g): dF*/dT = dg / T; d = x_f - Phi x0 - o,
    # so dT*/dx0 = Phi^T nu with nu = -dT*/dd (the fuel family's convention)
    a = problem.acceleration
    trajectory = collocated_trajectory(tr, nlp, rows, U / nlp.umax * a, -p * T / dg, 1.0,
                                       magnitude=a)
    stats = dict(
        node_directions=U / nlp.umax, primer_normal=p, duration_slope=dg,
        terminal_residual=reached, linearisations=runs, linearisation_change=change,
        **collocation_accuracy(energy, tr.grid, rows, U,
                               control_map=lambda u: nlp.umax * unit_direction(u)))
    solution = Solution(problem=requested, status=status, cost=T, duration=T,
                        trajectory=zero_invalid(valid, trajectory),
                        stats=zero_invalid(valid, stats), method="condensed")
    return replace(solution, cost=jnp.where(valid, T, 0.0), duration=jnp.where(valid, T, 0.0))


_compiled = compiled(_min_time_condensed, static_argnames="options")

DEFAULT_SEGMENTS, DEFAULT_POINTS = 16, 8
LADDER = MeshLadder(tuple((k, DEFAULT_POINTS) for k in (16, 32, 64, 128)))
"""The uniform meshes `solve(problem)` climbs by method "condensed" (LGR)."""


def check_grid(mesh, method):
    check_segmented(mesh, "method 'condensed'", hint=": on LGL segments use method "
                    "'augmented-lagrangian' (the linear and two-body models)")


def run(problem, mesh, method, options: CondensedOptions) -> Solution:
    """Solve on one segmented LGR or LG mesh (breaks as fractions of [s0, s_f] from 0 to 1, or
    a solution's `LGRMesh` or `LGMesh`); outputs in SI (LVLH). jit-compiled once per mesh
    shape and options; vmap-able. Not differentiated (a parameter's derivative of t_f: finite
    differences, or the costates for the boundary states). t_min > 0 is not taken (a
    constant-thrust transfer cannot stretch to a longer time): a ValueError when concrete,
    INVALID_INPUT when traced. INFEASIBLE where t_max is too short (the target stays outside
    the reachable set)."""
    if is_concrete(problem.duration_bounds) and np.any(np.asarray(problem.bounds)[..., 0] > 0):
        raise ValueError("method 'condensed' takes duration_bounds [0, t_max] only (a constant-"
                         "thrust transfer cannot be stretched to a longer time)")
    return _compiled(problem, as_segmented(mesh), options)


def refine_transfer(problem, options, judge, ladder: MeshLadder = LADDER):
    """`solve(problem)` without a grid (or `solve(problem, ladder)`): uniform meshes of the
    ladder's shapes (LGR or LG segments by `ladder.scheme`) until the estimate meets the
    tolerance (the constant-thrust direction is smooth: no switches to align with); the last
    one's solution is INACCURATE otherwise. stats gain mesh_passes."""
    check_ladder(ladder)
    options = CondensedOptions() if options is None else options
    for done, (count, points) in enumerate(ladder.rungs, start=1):
        mesh = segmented_mesh(uniform_breaks(0.0, 1.0, count), points, ladder.scheme)
        solution = judge(run(problem, mesh, "condensed", options))
        if int(solution.status) != Status.INACCURATE:
            break
    return solution.replace(stats=dict(solution.stats, mesh_passes=done))


def default_grid(problem):
    return segmented_lgr(uniform_breaks(0.0, 1.0, DEFAULT_SEGMENTS), DEFAULT_POINTS)


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class ShootingSolution:
    """Outcome of `min_time_shooting`: duration t_f (s), the primer normal p (solver units),
    the terminal residual of the full-thrust control (solver units) and a flag."""

    duration: jax.Array
    primer_normal: jax.Array
    terminal_residual: jax.Array
    converged: jax.Array


def _shooting(problem, breaks, nodes, weights, options):
    twin = _fuel_twin(problem, 0.0)

    def at(T):
        return exact_linear_nlp(twin.replace(duration=T), breaks, nodes, weights)

    def margin(u, p):
        E, _, d = at(jnp.exp(u))
        return jnp.log(support(E, jnp.ones(E.shape[0], E.dtype), p) / (p @ d))

    def minimiser(T):
        E, _, d = at(T)
        return support_minimiser(E, jnp.ones(E.shape[0], E.dtype), d)

    def body(s):
        u, _, k = s
        p = jax.lax.stop_gradient(minimiser(jnp.exp(u)))
        g, dg = jax.value_and_grad(margin)(u, p)
        step = jnp.where(dg > 0, -g / dg, -0.5 * g)
        return u + step, step, k + 1

    u, step, _ = jax.lax.while_loop(
        lambda s: (jnp.abs(s[1]) > options.duration_tol) & (s[2] < options.duration_iterations),
        body, (jnp.log(rest_to_rest(problem)), jnp.asarray(jnp.inf), 0))
    T = jnp.exp(u)
    p = minimiser(T)
    E, _, d = at(T)
    res = jnp.max(jnp.abs(jnp.einsum("iab,ib->a", E, primer_directions(E, p)) - d))
    return ShootingSolution(T, p, res, jnp.abs(step) <= options.duration_tol)


_shooting_compiled = compiled(_shooting, static_argnames="options")


def min_time_shooting(problem: MinimumTimeTransfer, breaks, points: int = 8,
                      options: CondensedOptions = CondensedOptions()) -> ShootingSolution:
    """The minimum time of a transfer on the linear model (HCW or Tschauner-Hempel) by
    shooting: the reachable set's support function on the exact Yamanaka-Ankersen flow,
    integrated by Gauss-Legendre quadrature (`points` nodes) on panels with the given breaks
    (fractions of [f0, f_f] from 0 to 1), no collocation; the module docstring's equation
    F*(T) = 1 solved the same way. An independent check of method "condensed"."""
    require_x64()
    problem.check()
    if problem.model != "linear":
        raise ValueError(f"min_time_shooting uses the linear model's exact flow, got model "
                         f"{problem.model!r}")
    return _shooting_compiled(problem, *panel_quadrature(breaks, points), options)
