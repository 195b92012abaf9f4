"""Minimum-time transfers (`jaxlpm.problems.min_time`) by the augmented-Lagrangian solver.

Initial guess: the minimum time of the linear system itself (Neustadt 1960; Hermes & LaSalle
1969), on the grid's quadrature. In the solver's units (s = n t, B = [0; I], Phi(s) = exp(A s)
in closed form, thrust acceleration a~) the unit control reaches x_f in a duration S iff

    p . d(S) <= a~ F_S(p) for every p,    d(S) = x_f - Phi(S) x_0,
    F_S(p) = int_0^S |B^T Phi(S - s)^T p| ds ~ (S / 2) sum_i w_i |v_i|,  v_i = B^T Phi(S - s_i)^T p

(F_S: the support function of the states the control adds), so the minimum time solves
a~ F*(S) = 1, F*(S) = min_{p . d = 1} F_S(p), with the primer direction u_i = v_i / |v_i| at the
minimiser p*. F_S is convex in p: Newton from the energy-optimal p (the Gramian's W^-1 d).
On the chief's true anomaly (eccentric chiefs, two-body: `anomaly_min_time_ocp`) the same with
the Tschauner-Hempel system, Phi(f_f, f_i) the Yamanaka-Ankersen STM and B(f) = [0; I / (1 +
e cos f)^3] (`tschauner_hempel_linear_flow`; `LinearFlow` holds either system).
S: Newton on log(a~ F*) against log S (exact for F* ~ S^q: q = 2 for a short rest-to-rest
transfer, q ~ 1 for a drift-dominated low-thrust one of many orbits), dF*/dS at fixed p* (the
envelope theorem), from max(t_lb, 2 sqrt(|dr| / a) + |dv| / a) (`duration_lower_bound`, and the
rest-to-rest bang-bang time plus the velocity change at full thrust), within
[max(t_min, t_lb), t_max]. States and controls: the energy-optimal QP of the same transcription
with weights |v_i| (its control ~ v_i / |v_i| times the thrust needed), directions normalised.
Multipliers: the QP's, Lambda = c Lambda_QP with c from dL/ds_f = 1 + Lambda . dc/ds_f = 0, and
from stationarity in u_i at |u_i| = 1, nu_i = -u_i . (dc/du_i)^T Lambda / 2. Penalty: the first
rho of the AL's schedule rho0 growth^k at which the inner problem's reduced Hessian at the
guess is positive definite (the AL is exact only above such a threshold; Nocedal & Wright 2006,
Thm 17.5: below it the solution is a saddle of the inner problem).

The inner Newton-KKT systems, the guess's QP and the convexity test are solved by the condensed
elimination (`CondensedSecondOrder`). Its steps meet the linearised defects only to ~1e-12 on
transfers of several orbits (they lose digits as the states grow along the orbits), which the
l1 merit used to reject near a solution, ending the inner solves at the iteration limit; the
line search now also takes a full step that halves the KKT residual (`jaxlpm.nlp.newton`), and
duan's case takes the same 2 Newton iterations as with the dense LU, 0.025 s instead of
0.186 s (BENCHMARKS.md).
"""

import dataclasses
import math
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from ..compilation import compiled, pipelined
from .._validation import is_concrete
from ..collocation import Grid, lg
from ..collocation.segments import CONDENSED_SCHEMES, Mesh, SegmentedMesh, tau_mesh
from ..linalg import cholesky_solve
from ..dynamics import hcw_flow, yamanaka_ankersen_stm
from ..orbits import time_from_true_anomaly
from ..problems.min_time import (MinimumTimeTransfer, anomaly_min_time_ocp, anomaly_of_time,
                                 anomaly_solution, duration_lower_bound, energy_ocp,
                                 min_time_ocp, to_solution)
from ..problems.energy_optimal import scaled_state
from ..problems.scaling import length_scale
from ..nlp.ocp import PathPenalty
from ..nlp.reachable import support, support_minimiser
from ..nlp.transcription import equality, pack, state_tau, unpack
from ..status import Status
from ..nlp.augmented_lagrangian import ALOptions, augmented_lagrangian
from ..nlp.condensed import CondensedSecondOrder
from ..nlp.newton import NewtonOptions, newton_step
from ..solution import Solution
from . import min_time_condensed
from .family import FamilySolver
from .min_time_condensed import CondensedOptions, rest_to_rest
from .refine import MeshLadder, refine

MIN_POINTS = {"LGL": 4, "LG": 3, "LGR": 3}
DURATION_ITERATIONS = 50   # Newton on log S (a handful where log F* is smooth in log S)
DURATION_TOL = 1e-12       # relative step in S at which Newton stops: near the round-off of
#                            the quadrature sum, so a resolved transfer's guess is the
#                            collocated solution to the discretisation error


@dataclass(frozen=True)
class LinearFlow:
    """The linear system of the minimum-time guess (module docstring), in the solver's units:
    the primer basis E(S) = Phi(s0 + S, s_i) B(s_i) (n, 6, 3) at the grid's collocation points
    s_i = s0 + S (tau_i + 1) / 2, the target d(S) = x_f(s0 + S) - Phi(s0 + S, s0) x0 and the
    thrust acceleration a~ (|u| = a~)."""

    basis: object
    target: object
    accel: jax.Array


def hcw_linear_flow(params) -> LinearFlow:
    """HCW on s = n t (`min_time_ocp`'s params): Phi(s) = exp(A s) in closed form, B = [0; I]."""
    return LinearFlow(
        basis=lambda S, grid: jax.vmap(hcw_flow)(0.5 * S * (1.0 - grid.points))[:, :, 3:],
        target=lambda S: params["xf"] - hcw_flow(S) @ params["x0"], accel=params["accel"])


def tschauner_hempel_linear_flow(problem: MinimumTimeTransfer) -> LinearFlow:
    """The linear model on the true anomaly (`anomaly_min_time_ocp`'s linear model, any e):
    Phi the Yamanaka-Ankersen STM, B(f) = [0; I / (1 + e cos f)^3], the scaled Tschauner-Hempel
    state. It also seeds the two-body model: the directions and duration it gives are
    physical."""
    o = problem.orbit
    L, f0 = length_scale(problem), problem.orbit.f0

    def stm(f, f_from):
        dt = time_from_true_anomaly(o, f) - time_from_true_anomaly(o, f_from)
        return yamanaka_ankersen_stm(f, f_from, dt, o.e, o.k2)

    def basis(S, grid):
        return jax.vmap(lambda f: stm(f0 + S, f)[:, 3:] / (1.0 + o.e * jnp.cos(f)) ** 3)(
            f0 + 0.5 * S * (grid.points + 1.0))

    def th_state(x, f):
        return scaled_state("linear", x, f, o.e, o.k2, o.mean_motion, L)

    def target(S):
        return th_state(problem.xf, f0 + S) - stm(f0 + S, f0) @ th_state(problem.x0, f0)

    return LinearFlow(basis, target, problem.acceleration / (L * o.k2**2))


def _dual(S, flow: LinearFlow, grid):
    """p* = argmin F_S(p) subject to p . d(S) = 1 (see the module docstring;
    `jaxlpm.nlp.reachable.support_minimiser` with the quadrature weights times S / 2)."""
    return support_minimiser(flow.basis(S, grid), 0.5 * S * grid.weights, flow.target(S))


def _duration(flow: LinearFlow, grid, S0, lo, hi):
    """S with a~ F*(S) = 1 (or the end of [lo, hi] nearest to it), by Newton on log S."""
    def log_margin(u, p):                          # log(a~ F_S(p) / p . d(S)), S = e^u
        S = jnp.exp(u)
        return jnp.log(flow.accel * support(flow.basis(S, grid), 0.5 * S * grid.weights, p)
                       / (p @ flow.target(S)))

    def body(state):
        u, _, k = state
        g, dg = jax.value_and_grad(log_margin)(u, _dual(jnp.exp(u), flow, grid))
        # where log F* is not increasing in log S, the step of F* ~ S^2 (S <- S sqrt(m))
        step = jnp.where(dg > 0, -g / dg, -0.5 * g)
        u_new = jnp.clip(u + step, jnp.log(lo), jnp.log(hi))
        u_new = jnp.where(jnp.isfinite(u_new), u_new, u)
        return u_new, u_new - u, k + 1

    u0 = jnp.clip(jnp.log(S0), jnp.log(lo), jnp.log(hi))
    u, _, _ = jax.lax.while_loop(
        lambda s: (jnp.abs(s[1]) > DURATION_TOL) & (s[2] < DURATION_ITERATIONS), body,
        (u0, jnp.asarray(jnp.inf, u0.dtype), 0))
    return jnp.exp(u)


def initial_guess(ocp, grid, duration_floor, flow: LinearFlow | None = None, start=None):
    """(z0, equality multipliers, direction multipliers nu (n,)) for the minimum-time problem
    `ocp`; duration_floor: a lower bound on s_f - s0 (see the module docstring); flow: the
    linear system the duration and directions come from (default HCW on `ocp`'s params);
    start: the first s_f - s0 of the duration's Newton (default the rest-to-rest bang-bang
    span of `ocp`'s ends)."""
    params = ocp.params
    flow = hcw_linear_flow(params) if flow is None else flow
    if start is None:
        a = params["accel"]
        d = params["xf"] - params["x0"]
        start = (2.0 * jnp.sqrt(jnp.linalg.norm(d[:3]) / a) + jnp.linalg.norm(d[3:]) / a)
    lo, hi = ocp.final_bounds - ocp.s0
    S = _duration(flow, grid, jnp.maximum(duration_floor, start), jnp.maximum(lo, duration_floor),
                  hi)
    v = jnp.linalg.norm(jnp.einsum("kia,i->ka", flow.basis(S, grid), _dual(S, flow, grid)),
                        axis=1)
    weights = jnp.maximum(v, jnp.finfo(v.dtype).eps * jnp.max(v))
    eo = energy_ocp(ocp, S, weights)
    zero = pack(jnp.zeros((state_tau(grid).shape[0], ocp.n_x)), jnp.zeros((grid.n, ocp.n_u)),
                eo.sf, eo)
    z_qp, lam_qp = newton_step(eo, grid, zero, CondensedSecondOrder)
    X, U, _ = unpack(z_qp, eo, grid)
    norm = jnp.linalg.norm(U, axis=1, keepdims=True)
    U = U / jnp.where(norm > 0.0, norm, 1.0)
    ocp = ocp.replace(sf=ocp.s0 + S)
    z0 = pack(X, U, ocp.sf, ocp)

    def constraints(z):
        return equality(z, ocp, grid)

    # Lambda = c Lambda_QP with dL/ds_f = dphi/ds_f + Lambda . dc/ds_f = 0
    dc_dsf = jax.jvp(constraints, (z0,), (jnp.zeros_like(z0).at[-1].set(1.0),))[1]
    dphi_dsf = jax.grad(lambda sf: ocp.terminal_cost(X[0], X[-1], sf, ocp.params))(ocp.sf)
    lam = -dphi_dsf * lam_qp / (lam_qp @ dc_dsf)
    _, grad_u, _ = unpack(jax.vjp(constraints, z0)[1](lam)[0], ocp, grid)
    return z0, lam, -0.5 * jnp.sum(grad_u * U, axis=1)


def _direction_penalty(nu, rho, n_bounds=0):
    """`PathPenalty` with multipliers nu of the unit-direction equalities and zero ones for
    n_bounds final-s bounds."""
    return PathPenalty(jnp.zeros((nu.size, 0), nu.dtype), nu[:, None],
                       jnp.zeros(n_bounds, nu.dtype), rho)


def _first_convex_penalty(ocp, grid, z0, lam0, nu0, options: ALOptions):
    """The first rho of the AL's schedule rho0 growth^k (up to rho_max) at which the reduced
    Hessian of the inner problem at (z0, lam0, nu0), M0 + rho J^T J (M0 that of the
    Lagrangian, J the rows 2 u_i^T of the directions' constraints on the null space of the
    linearised defects, |u_i| = 1), is positive definite (its Cholesky factor is finite);
    rho0 if none is. The final-s bounds are left out: their penalty only adds to it."""
    steps = math.ceil(math.log(options.rho_max / options.rho0) / math.log(options.rho_growth))
    rhos = jnp.minimum(options.rho0 * options.rho_growth ** jnp.arange(steps + 1.0),
                       options.rho_max)
    la = CondensedSecondOrder(ocp.replace(final_bounds=None,
                                          penalty=_direction_penalty(nu0, 0.0)), grid, z0)
    _, _, M0, T = la.hessian(la.prepare(z0, lam0), z0, lam0)
    _, U, _ = unpack(z0, ocp, grid)
    J = 2.0 * jnp.einsum("ia,iak->ik", U, T[la.idx[:, ocp.n_x:]])
    ones = jnp.ones(M0.shape[0], M0.dtype)
    positive = jax.vmap(
        lambda r: jnp.all(jnp.isfinite(cholesky_solve(M0 + r * J.T @ J, ones))))(rhos)
    return jnp.where(jnp.any(positive), rhos[jnp.argmax(positive)], options.rho0)


def _on_clock(clock):
    """(the OCP builder, the `Solution` builder) of the solver's clock: "hcw" (s = n t,
    `min_time_ocp`) or "anomaly" (the chief's true anomaly, `anomaly_min_time_ocp`)."""
    return ((min_time_ocp, to_solution) if clock == "hcw"
            else (anomaly_min_time_ocp, anomaly_solution))


def _lower_bound(problem, clock):
    """t_lb (s): `duration_lower_bound` on HCW; on the anomaly clock the same where the chief
    is circular on the linear model, else 0 (no bound)."""
    if clock == "hcw":
        return duration_lower_bound(problem)
    return jnp.where(problem.is_hcw(), duration_lower_bound(problem), 0.0)


def min_time_setup(problem, grid, options: ALOptions, clock="hcw"):
    """The solve's first stage: (the problem as requested and as solved, whether it is
    valid, whether t_max is below the proven lower bound t_lb (s) (then the solve runs on a
    harmless problem, like invalid input: the AL would spend its whole penalty schedule
    failing), t_lb, the starting point (z0, lam0, nu0) and the first penalty). clock: "hcw"
    (HCW transfers alone: the others are invalid) or "anomaly" (`_on_clock`)."""
    valid = problem.validity() & (problem.is_hcw() if clock == "hcw" else True)
    requested = problem.sanitized(valid)
    t_lb = _lower_bound(requested, clock)
    hopeless = valid & (t_lb > requested.bounds[1])
    problem = requested.sanitized(~hopeless)
    fixed = jax.lax.stop_gradient(_on_clock(clock)[0](problem, 0.0))   # a start: not
    #                                                                    differentiated
    if clock == "hcw":
        n = problem.orbit.mean_motion
        z0, lam0, nu0 = initial_guess(fixed, grid,
                                      jax.lax.stop_gradient(n * duration_lower_bound(problem)))
    else:       # the Tschauner-Hempel system's minimum time, from n times the bang-bang time
        start = jax.lax.stop_gradient(problem)
        o = start.orbit
        floor = anomaly_of_time(o, _lower_bound(start, clock)) - o.f0
        z0, lam0, nu0 = initial_guess(fixed, grid, floor, tschauner_hempel_linear_flow(start),
                                      o.mean_motion * rest_to_rest(start))
    rho0 = _first_convex_penalty(fixed.replace(sf=z0[-1]), grid, z0, lam0, nu0, options)
    return requested, problem, valid, hopeless, t_lb, (z0, lam0, nu0, rho0)


def min_time_solve(problem, grid, start, options: ALOptions, clock="hcw"):
    """The solve's second stage: the augmented Lagrangian from `min_time_setup`'s start."""
    z0, lam0, nu0, rho0 = start
    return augmented_lagrangian(_on_clock(clock)[0](problem, 0.0).replace(sf=z0[-1]), grid, z0,
                                lam0, options=options, linear_algebra=CondensedSecondOrder,
                                penalty0=_direction_penalty(nu0, rho0, n_bounds=2))


def min_time_solution(requested, problem, valid, hopeless, t_lb, grid, result,
                      clock="hcw") -> Solution:
    """The solve's last stage: the status (infeasibility is shown by the lower bound, or by
    the AL's certificate with the duration held at t_max, `run`) and the `Solution`."""
    al_infeasible = result.status == Status.INFEASIBLE
    shown = hopeless | (al_infeasible & (result.path_multipliers.bounds[1] > 0.0))
    status = jnp.where(shown, Status.INFEASIBLE,
                       jnp.where(al_infeasible, Status.STALLED, result.status))
    status = jnp.where(valid, status, Status.INVALID_INPUT).astype(jnp.int32)
    make_ocp, make_solution = _on_clock(clock)
    solution = make_solution(problem, make_ocp(problem, 0.0), grid, result, status,
                             valid & ~hopeless, t_lb)
    return dataclasses.replace(solution, problem=requested)


_setup = compiled(min_time_setup, static_argnames=("options", "clock"))
_solve = compiled(min_time_solve, static_argnames=("options", "clock"))
_solution = compiled(min_time_solution, static_argnames="clock")


def _compiled(problem, grid, options, clock):
    """The minimum-time transfer as its three stages (`min_time_setup`, `min_time_solve`,
    `min_time_solution`), each compiled apart: the first solve of a signature compiles them
    side by side (`pipelined`)."""
    def run():
        requested, solved, valid, hopeless, t_lb, start = _setup(problem, grid, options,
                                                                 clock=clock)
        result = _solve(solved, grid, start, options, clock=clock)
        return _solution(requested, solved, valid, hopeless, t_lb, grid, result, clock=clock)

    return pipelined(run, _setup, problem, grid, options, clock=clock)


LGL_SEGMENTS_OPTIONS = ALOptions(inner=NewtonOptions(max_iterations=30, stall_iterations=0,
                                                     tol_optimality=1e-8))
"""The augmented Lagrangian's default on LGL meshes: its inner Newton-KKT stationarity stops at
1e-8, not 1e-10. On LGL segments (each holds its break rows, tied by linkage conditions) the
line search stalls with the stationarity at 4e-6 to 6e-6, where the round-off of the merit
and of the KKT residual hides every step, so no subproblem ends SUCCESS and the solve ends
MAX_ITERATIONS after 30 outer iterations, with the path residual at 1e-15 (0.05 N on 200 kg
to 3 km, 1.07 orbits of a circular chief, on 8 x 8 and 16 x 8 LGL points; the dense LU
stalls alike). With 1e-8 both end SUCCESS after 9-10 outer iterations, stationarity 4e-10
and 6e-10, t_f within 1.2e-12 of the stalled solve's (measured 2026-12-07)."""


def _scheme(grid):
    """The collocation scheme of a `MeshLadder`, `SegmentedMesh`, `Mesh` or `Grid`; None for
    anything else (such as None, the default ladder)."""
    if isinstance(grid, MeshLadder):
        return grid.scheme
    if isinstance(grid, SegmentedMesh):
        return grid.grid.scheme
    if isinstance(grid, Mesh):
        return grid.segment.scheme
    return grid.scheme if isinstance(grid, Grid) else None


def _lgl_segments(grid) -> bool:
    return _scheme(grid) == "LGL" and not isinstance(grid, Grid)


def default_options(method, grid):
    """The options of a solve that passes none on `grid` (a grid, a mesh, a `MeshLadder`, or
    None for the default ladder): `LGL_SEGMENTS_OPTIONS` on LGL segments, else the method's
    defaults."""
    if method == "augmented-lagrangian":
        return LGL_SEGMENTS_OPTIONS if _lgl_segments(grid) else ALOptions()
    return CondensedOptions()


DEFAULT_POINTS = 32
LADDER = MeshLadder(((2, 16), (4, 16), (8, 16), (16, 16)))
"""The meshes `solve(problem)` climbs: from 32 points (the default grid's size) to 256 (the
augmented Lagrangian's inner KKT systems are dense)."""


def check_grid(grid, method):
    if method == "condensed":
        return min_time_condensed.check_grid(grid, method)
    if isinstance(grid, SegmentedMesh):
        grid = tau_mesh(grid)
    if isinstance(grid, Mesh):
        scheme, n = grid.segment.scheme, grid.segment.n
    elif isinstance(grid, Grid):
        scheme, n = grid.scheme, grid.n
    else:
        raise ValueError(f"grid must be a jaxlpm Grid (lgl(n), lg(n), lgr(n): n points) or "
                         f"a Mesh (lgr_mesh(k, n), lg_mesh(k, n), lgl_mesh(k, n), "
                         f"segmented_lgl(breaks, n)), got "
                         f"{grid!r:.60}")
    if n < MIN_POINTS[scheme]:
        raise ValueError(f"minimum-time transfers need at least {MIN_POINTS[scheme]} "
                         f"{scheme} points{' per segment' if isinstance(grid, Mesh) else ''}, "
                         f"got {n}")


def refine_transfer(problem, options, judge, ladder: MeshLadder | None = None):
    """`solve(problem)` without a grid, or `solve(problem, ladder)`. Method "condensed"
    (`CondensedOptions`): uniform meshes of the ladder's shapes (default
    `min_time_condensed.LADDER`; `min_time_condensed.refine_transfer`). Method
    "augmented-lagrangian": the ladder's meshes (default `LADDER`, LGR; LG and LGL
    ladders too), segments split where the estimate is largest (`jaxlpm.solvers.refine`),
    until the estimate meets the tolerance. Each rung starts from its own minimum-time guess
    of the linear system (module docstring), which already carries the duration and the
    primer directions of the transfer: it needs no warm start from the rung before."""
    if isinstance(options, CondensedOptions):
        return min_time_condensed.refine_transfer(
            problem, options, judge, min_time_condensed.LADDER if ladder is None else ladder)
    options = ALOptions() if options is None else options
    return refine(lambda mesh, z0: run(problem, mesh, "augmented-lagrangian", options),
                  lambda solution, mesh: None, LADDER if ladder is None else ladder, judge)


def hcw_clock(problem) -> bool:
    """The problem is concretely HCW (model "linear", e = 0 for every member): the augmented
    Lagrangian's "hcw" clock, s = n t. Any other problem takes the "anomaly" clock, a traced
    one on the linear model too, whatever its members' eccentricities (a sweep or Monte Carlo
    batch: the chief's true anomaly is the clock of every e, HCW's included)."""
    return (problem.model == "linear" and is_concrete(problem.orbit.e)
            and bool(np.all(np.asarray(problem.orbit.e) == 0.0)))


def _linear_first(problem) -> bool:
    """Whether the default grid is one LG grid and refinement climbs by the augmented
    Lagrangian: concretely HCW transfers, and traced ones on the linear model (their
    eccentricity is not known on the host). Every other problem defaults to method
    "condensed" on segments."""
    return problem.model == "linear" and (not is_concrete(problem.orbit.e) or hcw_clock(problem))


def run(problem, grid, method, options, clock=None) -> Solution:
    """Solve a `MinimumTimeTransfer` on `grid`; outputs in SI (LVLH, m, m/s, m/s^2, s).

    Method "augmented-lagrangian", on LGL, LG, LGR grids or meshes (`LGRMesh`, `LGMesh`,
    `LGLMesh`, a `SegmentedMesh`): jit-compiled once per grid size (and options); vmap- and
    grad-able (implicit differentiation at the KKT point). HCW transfers (model "linear",
    e = 0) on s = n t (`min_time_ocp`); eccentric chiefs on the linear model and the
    "two-body" model on the chief's true anomaly (`anomaly_min_time_ocp`), started from the
    Tschauner-Hempel system's minimum time (`tschauner_hempel_linear_flow`). Not the "j2"
    model: a free final anomaly moves the collocation points, and the J2 chief is known at a
    point only by integrating to it (ValueError; method "condensed" on LGR or LG segments
    solves it). Traced bad input gives status INVALID_INPUT and zeroed outputs. INFEASIBLE
    only where infeasibility is shown: t_max below `duration_lower_bound` (HCW; then no
    solve runs: outputs zero, stats["duration_lower_bound"] the bound), or the AL's
    certificate (the violation stalls with the penalty at its cap) with the t_max bound
    active. Any other such stall ends STALLED. Without duration bounds every HCW request is
    feasible (HCW is controllable with every eigenvalue on the imaginary axis, so bounded
    thrust reaches any state from any state; Lee & Markus 1967): a stall there typically
    means a grid too coarse for the transfer's revolutions (the state oscillates once per
    orbit, and a global polynomial needs several points per orbit: 64 LG points resolve the
    5 orbits of a 0.01 N transfer in the tests, 16 do not).

    clock: the augmented Lagrangian's, "hcw" or "anomaly" (`_on_clock`), where the caller
    knows it of a traced batch (`jaxlpm.batch.refine`: "hcw" where every member is circular);
    None: "hcw" where `hcw_clock` (concretely HCW), else "anomaly" (traced linear members
    too, so a sweep or Monte Carlo batch of eccentric chiefs is solved, not INVALID_INPUT).

    Method "condensed" (every model and eccentricity), on a `SegmentedMesh` of LGR or LG
    segments: `jaxlpm.solvers.min_time_condensed.run`."""
    if method == "condensed":
        return min_time_condensed.run(problem, grid, method, options)
    if problem.model == "j2":
        raise ValueError("method 'augmented-lagrangian' solves the 'linear' and 'two-body' "
                         "models (its free final anomaly moves the collocation points, and a "
                         "J2 chief is known only by integration); method 'condensed' on LGR "
                         "or LG segments takes the 'j2' model")
    mesh = tau_mesh(grid) if isinstance(grid, SegmentedMesh) else grid
    if clock is None:
        clock = "hcw" if hcw_clock(problem) else "anomaly"
    return _compiled(problem, mesh, options, clock)   # traced too: one program, not op by op


def _default_grid(problem):
    return (lg(DEFAULT_POINTS) if _linear_first(problem)
            else min_time_condensed.default_grid(problem))


def _condensed_takes(mesh) -> bool:
    """Method "condensed" is the default on segments it can eliminate (LGR, LG)."""
    return _scheme(mesh) in CONDENSED_SCHEMES


def _default_method(problem, grid):
    if isinstance(grid, SegmentedMesh) and _condensed_takes(grid):
        return "condensed"
    return "augmented-lagrangian"


def refine_method(problem, ladder):
    """The method refinement climbs `ladder` (None: the default ladder) with: the augmented
    Lagrangian on HCW and on LGL ladders, else "condensed"."""
    if _linear_first(problem) or (ladder is not None and not _condensed_takes(ladder)):
        return "augmented-lagrangian"
    return "condensed"


FAMILY = FamilySolver(
    problem=MinimumTimeTransfer,
    methods={"augmented-lagrangian": ALOptions, "condensed": CondensedOptions},
    run=run, default_grid=_default_grid, check_grid=check_grid,
    default_method=_default_method, refine=refine_transfer, refine_method=refine_method,
    ladders=True, default_options=default_options)
