"""Minimum-duration finite burn of a J2 long-range intercept (Tan, Yan, Zhou & Tang 2011, §2.5,
eq. 20-21): LGL collocation of the burn arc joined to the J2 coast.

A vehicle coasts from state0 at t = 0 (`FiniteBurnIntercept`: its `ImpulsiveIntercept` and the
engine), fires a constant thrust F along a free unit direction u_hat from t_s to t_e = t_s + D,
then coasts to t_f, where it must be at r_target. Inertial Earth-centred equatorial frame, SI
units (m, m/s, kg, s, N):

    minimise    D  over t_s, D, u_hat(t)
    subject to  dr/dt = v,  dv/dt = a_grav(r) + (F / m(t)) u_hat,  |u_hat| = 1  (t_s..t_e)
                m(t) = m0 - mdot (t - t_s),  mdot = F / (Isp g0)   (constant mass flow)
                [r, v](t_s) = coast of state0 from 0 to t_s
                r(t_f) = r_target, r(t_f) the coast of [r, v](t_e) from t_e to t_f
                0 <= D <= max_duration

a_grav is two-body + J2 (`jaxlpm.dynamics.gravity.inertial_rhs`), the coasts are
`jaxlpm.dynamics.propagation.propagate` (Dopri8). Fuel = mdot D (the mass is known in closed
form, so it is no collocated state).

For a given t_s the arc is an `OptimalControlProblem` in the pattern of
`jaxlpm.problems.min_time`: independent variable s = (t - t_s) / T (T the initial-guess
duration: time scaled by the burn), free final s_f = D / T (cost s_f, bounds
[0, max_duration / T]), state [r / L, v / V] with L = 1e7 m, V = sqrt(mu / L), control u_hat
with the path equality |u_hat|^2 - 1 = 0, on an LGL grid (`lgl(n)`: the paper's "n nodes",
eq. 8-14), solved by the augmented-Lagrangian solver around Newton-KKT. Boundary conditions:
the start state (exact, the coast to t_s) and the end position after the coast, replaced by its
second-order Taylor model about the current iterate,
    r_f + A dx + v_f dtau + (1/2) [H(dx, dx) + 2 dtau (dv_f/dx) dx + a_f dtau^2]
(A = dr_f/dx_e by forward-mode autodiff through the coast, H and dv_f/dx from the variational
equations, dtau the change of the coast duration t_f - t_e), since the solver needs the
boundary's Hessian and diffrax's adjoint gives no second derivatives. The model is rebuilt at
each solution until the nonlinear terminal residual is below `tol_boundary`; at that fixed
point values and first derivatives are exact, so it is a KKT point of the problem above.

The burn start: the arc problem's optimal D*(t_s) has the derivative (envelope theorem)
dD*/dt_s = T lambda . dc/dt_s, lambda the boundary multipliers, dc/dt_s = [-f(x_s) / scale,
-v_f / L] (f the coast's right-hand side: a coast's derivative in its end time); t_s is the
root of dD*/dt_s, found by secant steps (from eq. (2)'s start and a 1 s probe downhill, each
arc solve warm-started from the last) kept inside t_s0 +- T/4. t_s is kept
outside the collocated problem: as a constant state its LGL defects would be linearly
dependent (the LGL D has rank n - 1 and a state whose rate depends on no state adds none),
making the Newton-KKT matrix singular.

Initial guess (the paper's eq. 2): the burn centred on the impulsive burn time t_b with the
duration T = m0 |dv| / F, t_s0 = t_b - T / 2, direction along dv; nodal states: the coast from
t_s plus the constant-acceleration increments (F / m0) u_hat (t - t_s) in velocity and half
its time integral in position; the multipliers by least squares there, those of the
unit-direction equality with them (`least_squares_start`). The impulse (t_b, dv)
is the problem's seed, or else the intercept's impulsive solution (`jaxlpm.solvers.impulsive`,
its own compiled program).

`jaxlpm.solve(FiniteBurnIntercept(...), lgl(n))` (method "augmented-lagrangian"; one concrete
solve runs on lgl(n) padded to 21 points, `run`; without a grid, one concrete problem is solved
on lgl(5) and, while its estimate exceeds the tolerance, on 9, 13 and 21 points,
`refine_degree`; traced, on lgl(5)) returns a `Solution`
(frame "inertial", trajectory `jaxlpm.solution.FiniteBurn`, on lgl(n)):
  cost      the burn duration D (s), the objective (fuel = mdot D: stats["fuel"], and
            `propellant(mass, isp)` gives the same by the rocket equation)
  duration  t_f (s)
  delta_v   int F / m dt = isp g0 ln(m0 / (m0 - mdot D)) (m/s); controls(t) = F / m(t) u_hat(t)
            (m/s^2, inertial) during the burn, zero on the coasts; costates are not estimated
            (NaN)
  stats     t_start, t_end, burn_duration (s), fuel (kg), miss |r(t_f) - r_target| (m) of the
            Dopri8 coast from the collocated end state, duration_gradient dD*/dt_s at t_start
            (0 at the optimum), constraint_residual, path_residual, stationarity_residual (the
            last arc solve's, scaled units), search_iterations (t_s steps), arc_solves
            (augmented-Lagrangian solves), newton_iterations, node_masses (kg),
            node_directions (unit, inertial), seed_time (s), seed_dv (m/s), seed_status,
            the error estimate (`arc_accuracy`: error_position m, error_velocity m/s,
            relative_error, segment_error, path_violation); points (the LGL points of
            the grid `refine_degree` ended on; only without a grid)
  status    SUCCESS; INACCURATE (converged, the estimate above the tolerance); the seed's
            failure (an impulsive solve that failed: its status);
            INFEASIBLE (eq. (2)'s burn does not fit between 0 and t_f: the engine is too weak
            for the intercept; or no burn within max_duration reaches r_target);
            MAX_ITERATIONS (the arc solve, the model rebuilds or the t_s search); NONFINITE
            (also a failed coast or variational integration); INVALID_INPUT (traced bad
            input). Outputs of a search that did not run, or non-finite ones, are zeros.
"""

import dataclasses
from dataclasses import dataclass, field

import jax
import jax.numpy as jnp
import numpy as np

from .._validation import is_concrete
from ..compilation import compiled, pipelined
from ..collocation import Grid, lgl
from ..collocation.padded import capacity, pad_grid
from ..dynamics.gravity import inertial_rhs
from ..dynamics.propagation import COAST_TANGENT, VARIATIONAL, propagate, solve_ode
from ..nlp.accuracy import check_flight, check_mesh, collocation_defects, unit_direction
from ..nlp.augmented_lagrangian import (ALOptions, augmented_lagrangian, least_squares_start,
                                        start_penalty)
from ..nlp.newton import NewtonOptions
from ..nlp.ocp import OptimalControlProblem
from ..nlp.transcription import pack, unpack
from ..problems.intercept import FiniteBurnIntercept
from ..solution import FiniteBurn, Solution, zero_invalid
from ..solution.intercept import PAD_CAPACITY
from ..solution.accuracy import accuracy_stats
from ..status import Status
from .family import FamilySolver
from .impulsive import compiled_solve as compiled_impulsive
from .refine import first_accurate

LENGTH = 1.0e7            # m: length scale of the collocated state
MIN_POINTS = 3
DEFAULT_POINTS = 5        # Tan 2011's Table 3: 5 LGL nodes resolve the burn


@dataclass(frozen=True)
class FiniteBurnOptions:
    """Static settings (hashable). max_models: Taylor-model rebuilds per arc solve;
    tol_boundary: max nonlinear terminal residual (scaled by L: 1e-10 = 1 mm); search: half
    width of the burn-start bracket about eq. (2)'s t_s0 as a fraction of eq. (2)'s duration,
    its secant iterations and tolerance (s); al: the augmented-Lagrangian settings of each
    arc solve. Its tol_path is 1e-7, not the default 1e-9: the LGL defects ask the nodal
    thrust accelerations' highest mode to cancel gravity's, which a constant-magnitude thrust
    meets only by second-order wiggles of its direction, so | |u|^2 - 1 | stalls near 2e-8
    (measured, 5 nodes; |u| is 1 to 1e-8); inner tol_optimality 1e-6 for the same reason."""

    max_models: int = 8
    tol_boundary: float = 1e-10
    search_half_width: float = 0.25
    search_iterations: int = 12
    search_tol: float = 1e-3
    al: ALOptions = field(default_factory=lambda: ALOptions(
        tol_path=1e-7, inner=NewtonOptions(max_iterations=30, tol_optimality=1e-6,
                                           stall_iterations=0)))


def _scales(p):
    """SI [r, v] = scale * collocated [r, v]."""
    return jnp.concatenate([jnp.full(3, LENGTH), jnp.full(3, jnp.sqrt(p["mu"] / LENGTH))])


def _rate(x, p):
    """Coast right-hand side f(x) (m/s, m/s^2)."""
    return inertial_rhs(x, jnp.zeros(3), p["mu"], p["j2"], p["r_eq"])


def _dynamics(s, x, u, data, p):
    scale = _scales(p)
    mass = p["mass"] - p["mass_rate"] * p["T"] * s
    rate = inertial_rhs(x * scale, p["thrust"] / mass * u, p["mu"], p["j2"], p["r_eq"])
    return p["T"] * rate / scale


def _no_running_cost(s, x, u, data, p):
    return 0.0 * s


def _duration(x0, xf, sf, p):
    return sf


def _unit_direction(s, x, u, data, p):
    return jnp.dot(u, u)[None] - 1.0


def _boundary(x0, xf, sf, p):
    """[start [r, v] (6), end position (3)], scaled; the end through its Taylor model."""
    scale, model = _scales(p), p["model"]
    dx = xf * scale - model["x_e"]
    dtau = model["t_e"] - (p["t_s"] + p["T"] * sf)     # change of the coast duration
    r_f = (model["r_f"] + model["A"] @ dx + model["v_f"] * dtau
           + 0.5 * jnp.einsum("ijk,j,k->i", model["H"], dx, dx)
           + dtau * model["dv_dx"] @ dx + 0.5 * model["a_f"] * dtau**2)
    return jnp.concatenate([x0 - p["x_s"] / scale, (r_f - p["r_target"]) / LENGTH])


def _coast_end(x_e, duration, p):
    """(end [r, v] (6,), dr_f/dx_e (3, 6), ok) of the coast from x_e: one forward-mode pass
    (`COAST_TANGENT`: the COAST integration and its six tangents)."""
    def position(x):
        end, ok = propagate(x, duration, p["mu"], p["j2"], p["r_eq"], integrator=COAST_TANGENT)
        return end[:3], (end, ok)

    A, (end, ok) = jax.jacfwd(position, has_aux=True)(x_e)
    return end, A, ok


def _second_order_stm(x_e, duration, p):
    """(Phi (6, 6), Psi (6, 6, 6), ok): first and second derivatives of the coast's final state
    in its initial state, from the variational equations Phi' = J Phi, Psi' = J Psi +
    f''(Phi, Phi) (J, f'' of the right-hand side by autodiff) integrated by Dopri8 at
    rtol = atol = 1e-9 in the coast's scaled variables. Used only for the curvature of the
    boundary model: it sets the outer convergence rate, not the converged point. ok: the
    integration succeeded (`solve_ode`)."""
    scale = _scales(p)

    def F(y):
        return inertial_rhs(y * scale, jnp.zeros(3), p["mu"], p["j2"], p["r_eq"]) / scale

    def rhs(t, Y):
        y, P, Q = Y
        J, Hf = jax.jacfwd(F)(y), jax.hessian(F)(y)
        return (F(y), J @ P, jnp.einsum("ij,jkl->ikl", J, Q)
                + jnp.einsum("imn,mk,nl->ikl", Hf, P, P))

    Y0 = (x_e / scale, jnp.eye(6), jnp.zeros((6, 6, 6)))
    ys, status = solve_ode(rhs, Y0, 0.0, duration, None, VARIATIONAL)
    _, P, Q = (leaf[-1] for leaf in ys)
    Phi = P * scale[:, None] / scale[None, :]
    Psi = Q * scale[:, None, None] / (scale[None, :, None] * scale[None, None, :])
    return Phi, Psi, status == Status.SUCCESS


def _end_model(z, ocp, grid):
    """The terminal coast's Taylor model at z, its scaled nonlinear residual, miss (m), ok
    (the coast and its variational equations integrated)."""
    p = ocp.params
    X, _, sf = unpack(z, ocp, grid)
    x_e = X[-1] * _scales(p)
    t_e = p["t_s"] + p["T"] * sf
    end, A, ok = _coast_end(x_e, p["t_f"] - t_e, p)
    Phi, Psi, ok_stm = _second_order_stm(x_e, p["t_f"] - t_e, p)
    model = {"r_f": end[:3], "v_f": end[3:], "A": A, "H": Psi[:3], "dv_dx": Phi[3:],
             "a_f": _rate(end, p)[3:], "x_e": x_e, "t_e": t_e}
    miss = jnp.linalg.norm(end[:3] - p["r_target"])
    return model, miss / LENGTH, miss, ok & ok_stm


def _empty_model():
    """Zeros of `_end_model`'s model (the initial carry of the arc's loop)."""
    shapes = {"r_f": 3, "v_f": 3, "A": (3, 6), "H": (3, 6, 6), "dv_dx": (3, 6), "a_f": 3,
              "x_e": 6, "t_e": ()}
    return {k: jnp.zeros(shape) for k, shape in shapes.items()}


def _arc_ocp(p, t_s, x_s, sf_guess, max_duration):
    """The collocated arc problem for burn start t_s (s), from the state x_s there; its
    terminal model (params["model"]) zeros until `_end_model` builds it."""
    return OptimalControlProblem(
        n_x=6, n_u=3, dynamics=_dynamics, running_cost=_no_running_cost, boundary=_boundary,
        s0=jnp.asarray(0.0), sf=sf_guess,
        params=dict(p, t_s=t_s, x_s=x_s, model=_empty_model()),
        terminal_cost=_duration, free_final=True, path_equality=_unit_direction,
        final_bounds=jnp.stack([0.0, max_duration / p["T"]]))


def _start(p, t_s):
    """([r, v] at burn start t_s: the coast of state0, ok)."""
    return propagate(p["state0"], t_s, p["mu"], p["j2"], p["r_eq"])


def _guess_z(ocp, grid, u):
    """Nodal states of eq. (2)'s burn: the coast from state0 through t_s plus the
    constant-acceleration increments along u; directions u; s_f = 1."""
    p = ocp.params
    dt = 0.5 * p["T"] * (grid.points + 1.0)
    coast, _ = propagate(p["state0"], p["t_s"] + p["T"], p["mu"], p["j2"], p["r_eq"],
                         ts=p["t_s"] + dt)
    a = p["thrust"] / p["mass"]
    rv = coast + jnp.concatenate([0.5 * a * dt[:, None] ** 2 * u, a * dt[:, None] * u], axis=1)
    return pack(rv / _scales(p), jnp.tile(u, (grid.n, 1)), 1.0, ocp)


def _solve_arc(p, grid, t_s, z, lam, penalty, max_duration, options, cold):
    """Minimum D for burn start t_s from (z, lam, the path penalty's multipliers): the
    augmented-Lagrangian arc solve, its terminal model rebuilt at each solution until the
    nonlinear residual is below tol_boundary (at least one solve). cold: start from the
    least-squares multipliers at z, those of the unit-direction path equality with them
    (`jaxlpm.nlp.augmented_lagrangian.least_squares_start`: from nu = 0 the first Hessian
    is singular across the directions, and the 20-node burn's first step was decided by
    round-off), instead of the given ones. Returns (z, lam, penalty, status, dD/dt_s (s/s),
    miss (m), [residuals], solves, Newton iterations, d[r, v](t_f)/d[r, v](t_e) (6, 6) SI,
    the state at t_s).

    One loop: each pass builds the model at z, then solves with it unless the boundary has
    converged (after at least one solve), the solves are spent or a step failed; so the
    program holds one model (its coast with its Jacobian, and the second-order variational
    integration; issue 21: two copies made the burn's program half as large again). Each
    solve starts from the last one's multipliers, nu included, with rho reset to rho0."""
    x_s, ok_start = _start(p, t_s)
    ocp0 = _arc_ocp(p, t_s, x_s, z[-1], max_duration)
    rho0 = jnp.asarray(options.al.rho0)

    def solve(z, lam, penalty, model, k):
        ocp = ocp0.replace(params=dict(ocp0.params, model=model), sf=z[-1])
        lam, penalty = jax.lax.cond(cold & (k == 0),
                                    lambda: least_squares_start(ocp, grid, z, rho0),
                                    lambda: (lam, penalty))
        res = augmented_lagrangian(ocp, grid, z, lam, options=options.al, penalty0=penalty)
        finite = jnp.all(jnp.isfinite(res.z)) & jnp.all(jnp.isfinite(res.multipliers))
        keep = lambda new, old: jax.tree_util.tree_map(lambda a, b: jnp.where(finite, a, b),
                                                       new, old)
        status = jnp.where(finite, res.status, Status.NONFINITE).astype(jnp.int32)
        residuals = jnp.stack([res.constraint_residual, res.path_residual,
                               res.stationarity_residual])
        warm = dataclasses.replace(res.path_multipliers, rho=rho0)
        return (keep(res.z, z), keep(res.multipliers, lam), keep(warm, penalty), status,
                res.inner_iterations.astype(jnp.int32), residuals)

    def step(c):
        z, lam, penalty, model, k, status, _, _, inner, residuals, _ = c
        new_model, resid, miss, ok = _end_model(z, ocp0, grid)
        ok = ok & ok_start & jnp.isfinite(resid)
        model = jax.tree_util.tree_map(lambda new, old: jnp.where(ok, new, old), new_model,
                                       model)
        resid, miss = jnp.where(ok, resid, jnp.inf), jnp.where(ok, miss, jnp.inf)
        status = jnp.where(ok, status, Status.NONFINITE).astype(jnp.int32)
        more = ((status == Status.SUCCESS) & (k < options.max_models)
                & ((k == 0) | (resid > options.tol_boundary)))
        z, lam, penalty, status, n_inner, residuals = jax.lax.cond(
            more, solve, lambda z, lam, penalty, model, k: (
                z, lam, penalty, status, jnp.asarray(0, jnp.int32), residuals),
            z, lam, penalty, model, k)
        return (z, lam, penalty, model, k + more, status, resid, miss, inner + n_inner,
                residuals, more)

    zero = jnp.asarray(0, jnp.int32)
    init = (z, lam, penalty, ocp0.params["model"], zero, jnp.asarray(Status.SUCCESS, jnp.int32),
            jnp.inf, jnp.inf, zero, jnp.full(3, jnp.inf), jnp.asarray(True))
    z, lam, penalty, model, k, status, resid, miss, inner, residuals, _ = jax.lax.while_loop(
        lambda c: c[-1], step, init)
    status = jnp.where((status == Status.SUCCESS) & (resid > options.tol_boundary),
                       Status.MAX_ITERATIONS, status).astype(jnp.int32)
    # envelope theorem: dD*/dt_s = T lambda_b . dc_b/dt_s (module docstring)
    dc = jnp.concatenate([-_rate(ocp0.params["x_s"], p) / _scales(p), -model["v_f"] / LENGTH])
    sensitivity = jnp.concatenate([model["A"], model["dv_dx"]])
    return (z, lam, penalty, status, p["T"] * jnp.dot(lam[-9:], dc), miss, residuals, k,
            inner, sensitivity, x_s)


def arc_accuracy(ocp, grid, X, U, sf, sensitivity):
    """`jaxlpm.solution.accuracy` stats (SI, inertial) of the collocated burn: the GPOPS-II
    estimate and the check-mesh flight of the renormalised direction over the arc (4 Newton
    steps: the burn's IVP is nonlinear), its error at the burn's end carried to the target
    by the coast's sensitivity d[r, v](t_f)/d[r, v](t_e) (first order: the coasts themselves
    are the Dopri8 propagation, verified apart): the largest of the two is the estimate of
    the flown miss."""
    check = check_mesh(grid)
    d = collocation_defects(ocp, check, grid, X, U, sf, unit_direction)
    flown = check_flight(ocp, check, grid, X, U, sf, unit_direction)
    errors = ((flown - d.states) * _scales(ocp.params)).reshape(-1, 6)
    return accuracy_stats(jnp.concatenate([errors, (sensitivity @ errors[-1])[None]]),
                          d.relative)


def n_multipliers(grid) -> int:
    """Equality multipliers of the arc problem: defects (n x 6) and boundary (6 + 3)."""
    return 6 * grid.n + 9


def _seed(problem: FiniteBurnIntercept):
    """(t_b (s), dv (3,) (m/s), status) of the impulse that seeds eq. (2): the user's, or the
    intercept's impulsive solution by the impulsive family's own compiled program
    (`jaxlpm.solvers.impulsive.compiled_solve`, the one a solve of the intercept runs; not a
    copy inside the burn's)."""
    if problem.seeded:
        return problem.seed_time, problem.seed_dv, jnp.asarray(Status.SUCCESS, jnp.int32)
    impulsive = compiled_impulsive(problem.intercept)
    return impulsive.stats["t_burn"], impulsive.stats["dv"], impulsive.status


def _finite_burn(problem: FiniteBurnIntercept, grid, options: FiniteBurnOptions,
                 seed) -> Solution:
    """The burn for the seed impulse (`_seed`) of the problem as given."""
    valid = problem.validity()
    problem = problem.sanitized(valid)
    ip = problem.intercept
    t_impulse, dv_impulse, seed_status = seed
    dv = jnp.linalg.norm(dv_impulse)
    T = problem.mass * dv / problem.thrust                         # eq. (2)
    t_s0 = t_impulse - 0.5 * T
    # eq. (2)'s burn must fit between 0 and t_f, else the engine is too weak for the intercept
    fits = (dv > 0.0) & (t_s0 > 0.0) & (t_impulse + 0.5 * T < ip.duration)
    search = valid & (seed_status == Status.SUCCESS) & fits
    p = {"state0": ip.state0, "r_target": ip.r_target, "t_f": ip.duration, "mu": ip.mu,
         "j2": ip.j2, "r_eq": ip.r_eq, "thrust": problem.thrust, "mass": problem.mass,
         "mass_rate": problem.mass_rate, "T": T}
    half_width = options.search_half_width * T
    lo, hi = t_s0 - half_width, t_s0 + half_width
    # x_s is not needed for the guess (`_guess_z` coasts from state0)
    ocp0 = _arc_ocp(p, t_s0, ip.state0, jnp.asarray(1.0), problem.max_duration)
    z0 = _guess_z(ocp0, grid, dv_impulse / jnp.where(dv > 0.0, dv, 1.0))

    def cond(c):
        k, t_a, _, t_b, _, _, _, _, st = c[:9]
        return (k < 2) | ((k < options.search_iterations) & (st == Status.SUCCESS)
                          & (jnp.abs(t_b - t_a) > options.search_tol))

    def body(c):
        k, t_a, g_a, t_b, g_b, z, lam, penalty, _, _, _, solves, inner, _, _ = c
        slope = (g_b - g_a) / jnp.where(t_b != t_a, t_b - t_a, 1.0)
        secant = jnp.where(slope > 0, t_b - g_b / jnp.where(slope > 0, slope, 1.0),
                           t_b - jnp.sign(g_b) * 0.5 * half_width)
        probe = t_b - jnp.sign(g_b) * 1.0                # 1 s downhill of eq. (2)'s start
        t_new = jnp.clip(jnp.select([k == 0, k == 1], [t_s0, probe], secant), lo, hi)
        z, lam, penalty, st, g, miss, res, n_solves, n_inner, sens, x_s = _solve_arc(
            p, grid, t_new, z, lam, penalty, problem.max_duration, options, k == 0)
        return (k + 1, t_b, g_b, t_new, g, z, lam, penalty, st, miss, res, solves + n_solves,
                inner + n_inner, sens, x_s)

    zero = jnp.asarray(0.0)
    init = (jnp.asarray(0, jnp.int32), t_s0, zero, t_s0, zero, z0,
            jnp.zeros(n_multipliers(grid)), start_penalty(ocp0, grid, options.al.rho0, z0.dtype),
            jnp.asarray(Status.SUCCESS, jnp.int32), zero,
            jnp.zeros(3), jnp.asarray(0, jnp.int32), jnp.asarray(0, jnp.int32),
            jnp.zeros((6, 6)), ip.state0)
    # no search without a seed that fits (unbatched, the branch is skipped)
    k, t_a, _, t_s, g, z, lam, _, status, miss, res, n_solves, inner, sens, x_s = jax.lax.cond(
        search, lambda c: jax.lax.while_loop(cond, body, c), lambda c: c, init)
    status = jnp.where((status == Status.SUCCESS) & (jnp.abs(t_s - t_a) > options.search_tol),
                       Status.MAX_ITERATIONS, status)
    status = jnp.select([~valid, seed_status != Status.SUCCESS, ~fits],
                        [Status.INVALID_INPUT, seed_status, Status.INFEASIBLE],
                        status).astype(jnp.int32)
    ocp = _arc_ocp(p, t_s, x_s, z[-1], problem.max_duration)
    X, U, sf = unpack(z, ocp, grid)
    duration = T * sf
    accuracy = arc_accuracy(ocp, grid, X, U, sf, sens)

    def keep(x):
        return jnp.where(search & jnp.all(jnp.isfinite(x)), x, jnp.zeros_like(x))

    trajectory = FiniteBurn(
        grid=grid, state0=ip.state0, t_start=keep(t_s), t_end=keep(t_s + duration),
        node_states=keep(X * _scales(p)), node_directions=keep(U), thrust=problem.thrust,
        mass=problem.mass, mass_rate=problem.mass_rate, duration=ip.duration, mu=ip.mu,
        j2=ip.j2, r_eq=ip.r_eq)
    stats = dict(
        t_start=trajectory.t_start, t_end=trajectory.t_end, burn_duration=keep(duration),
        fuel=keep(problem.mass_rate * duration), miss=keep(miss), duration_gradient=keep(g),
        constraint_residual=keep(res[0]), path_residual=keep(res[1]),
        stationarity_residual=keep(res[2]), search_iterations=k, arc_solves=n_solves,
        newton_iterations=inner, node_masses=trajectory.node_masses,
        node_directions=trajectory.node_directions, seed_time=zero_invalid(valid, t_impulse),
        seed_dv=zero_invalid(valid, dv_impulse), seed_status=seed_status,
        **jax.tree_util.tree_map(keep, accuracy))
    return Solution(problem=problem, status=status, cost=stats["burn_duration"],
                    duration=ip.duration, trajectory=trajectory, stats=stats,
                    method="augmented-lagrangian", frame="inertial")


_compiled = compiled(_finite_burn, static_argnames="options")


def check_grid(grid, method):
    if not isinstance(grid, Grid) or grid.scheme != "LGL":
        raise ValueError(f"the burn arc is collocated on an LGL grid (lgl(n): n points), got "
                         f"{grid!r:.60}")
    if grid.n < MIN_POINTS:
        raise ValueError(f"a finite burn needs at least {MIN_POINTS} LGL points, got {grid.n}")


def unpadded(solution: Solution, grid) -> Solution:
    """A burn solved on a `PaddedGrid` as the burn on its own grid lgl(n) (`FiniteBurn.unpadded`:
    node rows gathered on the host, no program compiled per n)."""
    trajectory = solution.trajectory.unpadded(grid)
    stats = dict(solution.stats, node_masses=trajectory.node_masses,
                 node_directions=trajectory.node_directions)
    return solution.replace(trajectory=trajectory, stats=stats)


def run(problem, grid, method, options: FiniteBurnOptions) -> Solution:
    """Minimum-duration finite burn (module docstring) on an LGL grid: jit-compiled once per
    grid size, options and static structure (seed given or not); traceable (vmap over
    problems; not differentiable end to end: the t_s search is a while loop of solves).
    One concrete solve runs on the grid padded to `capacity(n, PAD_CAPACITY)` points
    (`jaxlpm.collocation.padded`; the padding pinned, `jaxlpm.nlp.transcription`): one
    program for every grid up to lgl(21) (issue 21: tan2011's burns on 5, 10 and 20 points
    compiled three programs of ~16 800 lines each). The same KKT point to the solver's
    tolerances: D to 3e-8 s, nodal states to 5e-5 m (experiments/finite_burn_padding.py).
    Unseeded, the impulsive seed is a program of its own: a first solve compiles it beside
    the burn's (`jaxlpm.compilation.pipelined`)."""
    solve_grid = grid
    if is_concrete(problem) and np.ndim(problem.thrust) == 0:
        solve_grid = pad_grid(grid.n, capacity(grid.n, PAD_CAPACITY))
    if problem.seeded:
        solution = _compiled(problem, solve_grid, options, _seed(problem))
    else:
        solution = pipelined(lambda: _compiled(problem, solve_grid, options, _seed(problem)),
                             compiled_impulsive, problem.intercept)
    return solution if solve_grid is grid else unpadded(solution, grid)


REFINE_POINTS = (DEFAULT_POINTS, 9, 13, PAD_CAPACITY)
"""The LGL grids `solve(problem)` climbs: the burn is one smooth arc, so its degree is raised
(p refinement) rather than the arc split; every grid up to `PAD_CAPACITY` points runs the same
padded program (`run`), so a rung compiles nothing."""


def refine_degree(problem, options, judge, points=REFINE_POINTS):
    """`solve(problem)` without a grid, for one concrete problem: the burn on lgl(n) for n in
    `points` (5, 9, 13, 21) until its error estimate meets the tolerance (`judge`); a failure
    that more points do not cure (not INACCURATE) ends it, and at the last grid INACCURATE
    stays. A batch of problems (thrust with a leading axis) is solved on lgl(5). stats gain
    "points", the LGL points of the grid it ended on."""
    if np.ndim(problem.thrust) != 0:
        return judge(run(problem, lgl(DEFAULT_POINTS), "augmented-lagrangian", options))
    solution, n = first_accurate(
        lambda n: judge(run(problem, lgl(n), "augmented-lagrangian", options)), points)
    return solution.replace(stats=dict(solution.stats, points=jnp.int32(n)))


FAMILY = FamilySolver(problem=FiniteBurnIntercept,
                      methods={"augmented-lagrangian": FiniteBurnOptions}, run=run,
                      default_grid=lambda problem: lgl(DEFAULT_POINTS), check_grid=check_grid,
                      refine=refine_degree, refine_method="augmented-lagrangian")
