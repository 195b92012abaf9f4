"""Minimum-time relative transfer with constant thrust magnitude and free direction.

    minimise    t_f
    subject to  x_dd = f(x) + (T / m) u_hat,   |u_hat| = 1 (the engine always fires at
                constant thrust, free direction; Duan & Dong 2011),
                x(0) = x0, x(t_f) = xf,  t_min <= t_f <= t_max
    LVLH frame (x radial out, y along-track, z orbit normal), m, m/s; thrust T in N, mass m in
    kg held constant (no mass flow: the paper gives no Isp).

f: HCW (a circular chief, mean motion n), Tschauner-Hempel (the linear model of an eccentric
one), two-body or J2 relative motion (`jaxlpm.problems.energy_optimal`). On HCW, as an
`OptimalControlProblem` (`min_time_ocp`): independent variable s = f0 + n t (the chief's true
anomaly), state [r / L, v / (L n)] with L = max(|r0|, |rf|, 1 m), control u_hat, acceleration
a~ = (T / m) / (L n^2), cost phi = s_f - s0 = n t_f, free final s with bounds n [t_min, t_max];
the unit direction is the path equality |u_hat|^2 - 1 = 0 at every collocation point. (A
throttleable engine, |u_hat| <= 1, has the same minimum time: the minimum-time engine always
fires at full thrust.) On an eccentric chief (linear model) and on the two-body model,
`anomaly_min_time_ocp`: the chief's true anomaly as s, its final value free, cost n t_f =
M(s_f) - M(f0) (Kepler's equation). The J2 model is solved by method "condensed"
(`jaxlpm.solvers.min_time_condensed`).

Lower bound (`duration_lower_bound`): two quantities of the HCW motion change only under thrust,
the centre of the in-plane ellipse x_c = 4 x + 2 y_d / n (the semi-major-axis offset) and the
out-of-plane amplitude sigma = sqrt(n^2 z^2 + z_d^2):

    d(n x_c / 2)/dt = a_y,     d sigma / dt = z_d a_z / sigma,  |d sigma / dt| <= |a_z|,

so the point (n x_c / 2, sigma) moves at speed <= |a| = T / m and every transfer takes at least
t_lb = |(n dx_c / 2, d sigma)| / (T / m): at low thrust the tangential delta-v n |dx_c| / 2
spent at the engine's rate. The minimum time can be well above it (the along-track drift
-3/2 n x_c gathered on the way must be undone too: 2.8 t_lb for the 0.01 N case of the tests).
"""

from dataclasses import dataclass, field, replace

import jax
import jax.numpy as jnp

import numpy as np

from .._validation import Checked, Rule, array_module, coerce_sequences
from ..constants import J2_EARTH, R_EARTH
from ..dynamics import hcw_drift, lvlh_frame_motion
from ..dynamics.chief import anomaly_rate, kepler_chief
from ..orbits import (KeplerOrbit, elements_to_state, time_from_true_anomaly,
                      true_anomaly_from_time)
from .energy_optimal import (MODELS, EnergyOptimalTransfer, control_scale, lvlh_dynamics,
                             lvlh_state, model_state, perigee_above_surface, scaled_state,
                             th_dynamics)
from .energy_optimal import collocation_accuracy as energy_accuracy
from .scaling import length_scale, state_scale
from ..nlp.accuracy import check_flight, check_mesh, collocation_defects, unit_direction
from ..nlp.ocp import OptimalControlProblem
from ..nlp.transcription import collocated_rows, collocation_s, costates, state_s, unpack
from ..solution import Collocated, Solution, zero_invalid
from ..solution.accuracy import accuracy_stats


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class MinimumTimeTransfer(Checked):
    """Minimise the transfer time t_f (s) from x0 to xf at constant thrust (module docstring).

    orbit            the chief's `KeplerOrbit` (SI, rad); t = 0 at its epoch; any e < 1
                     (method "augmented-lagrangian": HCW at e = 0, else on the true
                     anomaly, models "linear" and "two-body"; "condensed": every model,
                     `jaxlpm.solvers.min_time_condensed`)
    x0, xf           LVLH states [x, y, z, vx, vy, vz] (m, m/s; x radial outward, y
                     along-track, z orbit normal)
    thrust, mass     constant thrust magnitude (N) and mass (kg, held constant)
    duration_bounds  [t_min, t_max] (s; inf allowed; None: [0, inf))
    model            "linear" (HCW on a circular chief, Tschauner-Hempel on an eccentric
                     one), "two-body" or "j2" (static; `jaxlpm.problems.energy_optimal`)
    j2, r_eq         the J2 coefficient and equatorial radius (m) of the "j2" model
    """

    orbit: KeplerOrbit
    x0: jax.Array
    xf: jax.Array
    thrust: jax.Array
    mass: jax.Array
    duration_bounds: jax.Array = None
    model: str = field(default="linear", metadata=dict(static=True))
    j2: jax.Array = J2_EARTH
    r_eq: jax.Array = R_EARTH

    SHAPES = {"x0": (6,), "xf": (6,), "thrust": (), "mass": (), "duration_bounds": (2,),
              "j2": (), "r_eq": ()}

    def __post_init__(self):
        if self.duration_bounds is None:
            object.__setattr__(self, "duration_bounds", np.array([0.0, np.inf]))
        coerce_sequences(self)

    def replace(self, **kwargs) -> "MinimumTimeTransfer":
        return replace(self, **kwargs)

    @property
    def bounds(self):
        """[t_min, t_max] (s)."""
        return jnp.asarray(self.duration_bounds)

    @property
    def acceleration(self):
        """Thrust acceleration T / m (m/s^2)."""
        return self.thrust / self.mass

    def rules(self):
        """Validity rules, written once (`jaxlpm._validation.Checked`)."""
        xp = array_module(self)
        lo, hi = self.bounds[0], self.bounds[1]
        rules = [*self.orbit.rules(),
                 Rule("x0", xp.all(xp.isfinite(self.x0)), "finite (m, m/s)"),
                 Rule("xf", xp.all(xp.isfinite(self.xf)), "finite (m, m/s)"),
                 Rule("j2", xp.isfinite(self.j2), "finite"),
                 Rule("r_eq", xp.isfinite(self.r_eq) & (self.r_eq > 0.0),
                      "a positive equatorial radius in m")]
        if self.model != "linear":
            rules.append(Rule("orbit", perigee_above_surface(self.orbit.a, self.orbit.e,
                                                             self.r_eq),
                              f"an orbit whose perigee a (1 - e) is above r_eq on the "
                              f"{self.model!r} model"))
        return [*rules,
                Rule("thrust", xp.isfinite(self.thrust) & (self.thrust > 0.0),
                     "positive and finite (N)"),
                Rule("mass", xp.isfinite(self.mass) & (self.mass > 0.0),
                     "positive and finite (kg)"),
                Rule("duration_bounds", ~xp.isnan(lo) & ~xp.isnan(hi) & (lo >= 0.0)
                     & (lo < hi), "[t_min, t_max] with 0 <= t_min < t_max (s)"),
                Rule("xf", xp.any(self.x0 != self.xf),
                     "different from x0 (the minimum time of no transfer is 0)")]

    def static_rules(self) -> None:
        """The model, then the fields' shapes (`Checked.static_rules`)."""
        if self.model not in MODELS:
            raise ValueError(f"model must be one of {MODELS}, got {self.model!r}")
        super().static_rules()

    def is_hcw(self):
        """True where the transfer is on HCW (the linear model of a circular chief)."""
        return (self.model == "linear") & (self.orbit.e == 0.0)

    def harmless(self) -> "MinimumTimeTransfer":
        """A valid transfer (100 m along-track from rest, 1 N on 100 kg)."""
        return MinimumTimeTransfer(
            orbit=self.orbit.harmless(), x0=jnp.zeros(6),
            xf=jnp.array([0.0, 100.0, 0.0, 0.0, 0.0, 0.0]), thrust=1.0, mass=100.0,
            duration_bounds=jnp.array([0.0, jnp.inf]), model=self.model, j2=0.0,
            r_eq=R_EARTH)


def _dynamics(s, x, u, data, p):
    return hcw_drift(x, 1.0) + jnp.concatenate([jnp.zeros(3), p["accel"] * u])


def _no_running_cost(s, x, u, data, p):
    return 0.0 * s


def _weighted_energy(s, x, u, data, p):
    return 0.5 * data * jnp.dot(u, u)


def _elapsed(x0, xf, sf, p):
    return sf - p["s0"]


def _fixed_ends(x0, xf, sf, p):
    return jnp.concatenate([x0 - p["x0"], xf - p["xf"]])


def _unit_direction(s, x, u, data, p):
    return jnp.dot(u, u)[None] - 1.0


def min_time_ocp(problem: MinimumTimeTransfer, duration_guess) -> OptimalControlProblem:
    """The transfer as an `OptimalControlProblem` (see the module docstring); the initial
    final s is s0 + n * duration_guess."""
    o = problem.orbit
    n, scale = o.mean_motion, state_scale(problem)
    s0 = o.f0 + 0.0 * n
    params = {"x0": problem.x0 / scale, "xf": problem.xf / scale, "s0": s0,
              "accel": problem.acceleration / (length_scale(problem) * n**2)}
    return OptimalControlProblem(
        n_x=6, n_u=3, dynamics=_dynamics, running_cost=_no_running_cost, boundary=_fixed_ends,
        s0=s0, sf=s0 + n * duration_guess, params=params, terminal_cost=_elapsed,
        free_final=True, path_equality=_unit_direction,
        final_bounds=s0 + n * problem.bounds.astype(s0.dtype))


def _th_thrust(s, x, u, data, p):
    return th_dynamics(s, x, p["accel"] * u, data, p)


def _two_body_thrust(s, x, u, data, p):
    r, v = elements_to_state(p["orbit"], s)
    chief = jnp.concatenate([r, v])
    frame = lvlh_frame_motion(chief, p["mu"], None, p["r_eq"])
    return lvlh_dynamics(s, x, p["accel"] * u, (r, frame, p["n"] / anomaly_rate(chief)), p)


def _mean_anomaly_swept(x0, xf, sf, p):
    return p["n"] * time_from_true_anomaly(p["orbit"], sf)


@dataclass(frozen=True)
class _EndsOnAnomaly:
    """The boundary conditions on the anomaly clock: the target's scaled state depends on the
    free final anomaly (the Tschauner-Hempel map does; hashable, one compiled solver per
    model)."""

    model: str

    def __call__(self, x0, xf, sf, p):
        target = scaled_state(self.model, p["xf_lvlh"], sf, p["e"], p["k2"], p["n"],
                              p["length"])
        return jnp.concatenate([x0 - p["x0"], xf - target])


def anomaly_of_time(orbit: KeplerOrbit, t):
    """The true anomaly (rad, continuous) t seconds after the epoch; inf where t is."""
    finite = jnp.isfinite(t)
    return jnp.where(finite, true_anomaly_from_time(orbit, jnp.where(finite, t, 0.0)), jnp.inf)


def anomaly_min_time_ocp(problem: MinimumTimeTransfer, anomaly_guess) -> OptimalControlProblem:
    """The transfer on the chief's true anomaly s (any e; models "linear" and "two-body"), the
    clock of the energy-optimal transfer and its scaled states (`energy_optimal.transfer_ocp`:
    Tschauner-Hempel on the linear model, [r / L, v / (L n)] on two-body), driven by a~ u_hat
    (a~ = (T / m) over the model's control unit), the chief's conic evaluated at every point
    (a free final anomaly moves the points), cost phi = n t_f = M(s_f) - M(f0) (the mean
    anomaly swept, Kepler's equation), the final anomaly bounded by those at t_min and t_max,
    |u_hat| = 1 at every collocation point. The initial final anomaly is s0 + anomaly_guess."""
    o = problem.orbit
    L = length_scale(problem)
    s0 = o.f0 + 0.0 * L
    model = problem.model
    params = {"x0": model_state(problem, problem.x0, s0), "xf_lvlh": problem.xf, "s0": s0,
              "accel": problem.acceleration / control_scale(problem),
              "e": o.e, "k2": o.k2, "n": o.mean_motion, "length": L,
              "axes": jnp.ones(3, s0.dtype), "orbit": o, "mu": o.mu, "j2": None,
              "r_eq": problem.r_eq}
    return OptimalControlProblem(
        n_x=6, n_u=3, dynamics=_th_thrust if model == "linear" else _two_body_thrust,
        running_cost=_no_running_cost, boundary=_EndsOnAnomaly(model), s0=s0,
        sf=s0 + anomaly_guess, params=params, terminal_cost=_mean_anomaly_swept,
        free_final=True, path_equality=_unit_direction,
        final_bounds=anomaly_of_time(o, problem.bounds.astype(s0.dtype)))


def energy_ocp(ocp: OptimalControlProblem, duration_nd, weights) -> OptimalControlProblem:
    """The same dynamics and ends with cost 1/2 int w |u_hat|^2 ds (w: `weights` (n,) at the
    collocation points) over a fixed duration n t and no path constraints: a QP whose solution
    seeds the minimum-time solve."""
    return ocp.replace(running_cost=_weighted_energy, terminal_cost=None, free_final=False,
                       path_equality=None, path=None, final_bounds=None,
                       sf=ocp.s0 + duration_nd, node_data=weights)


def duration_lower_bound(problem: MinimumTimeTransfer):
    """t_lb (s) <= the minimum time of any transfer (module docstring): the distance between
    the ends' (n x_c / 2, sigma) over the thrust acceleration."""
    n = problem.orbit.mean_motion

    def invariants(x):
        return jnp.stack([2.0 * n * x[0] + x[4], jnp.hypot(n * x[2], x[5])])

    return jnp.linalg.norm(invariants(problem.xf) - invariants(problem.x0)) / problem.acceleration


def collocation_accuracy(problem: MinimumTimeTransfer, ocp, grid, X, U, sf):
    """`jaxlpm.solution.accuracy` stats (SI, LVLH) of the solution with scaled state rows X
    and directions U: the GPOPS-II estimate and the check-mesh flight with the engine along
    the renormalised interpolated direction (what the trajectory flies)."""
    check = check_mesh(grid)
    d = collocation_defects(ocp, check, grid, X, U, sf, unit_direction)
    # HCW with the direction fixed along the interpolant: linear, one Newton step
    flown = check_flight(ocp, check, grid, X, U, sf, unit_direction, newton_steps=1)
    return accuracy_stats((flown - d.states) * state_scale(problem), d.relative)


def to_solution(problem: MinimumTimeTransfer, ocp, grid, result, status, valid, t_lb):
    """The `Solution` (SI, LVLH) of the transcribed problem solved to `result` (an `ALResult`
    of `min_time_ocp`): duration t_f = (s_f - s0) / n (the cost), states and the thrust
    acceleration (T/m) u_hat unscaled, costates dJ/dx = (dJ~/dx~) / (n scale) (J = t_f,
    x~ = x / scale), zeros where `valid` is False (stats too, but for the lower bound).

    stats: node_s, state_s (s = s0 + n t at the collocation points and state rows),
    node_directions (u_hat), costates_scaled, multipliers, path_multipliers,
    constraint_residual, path_residual, stationarity_residual, complementarity (scaled
    units), outer_iterations, inner_iterations, history, duration_lower_bound (t_lb, s), and
    the error estimate (`collocation_accuracy`: error_position m, error_velocity m/s,
    relative_error, segment_error, path_violation)."""
    def keep(tree):
        return zero_invalid(valid, tree)

    n = problem.orbit.mean_motion
    X, U, sf = unpack(result.z, ocp, grid)
    rows_s, node_s = state_s(ocp, grid, sf), collocation_s(ocp, grid, sf)
    duration = keep((sf - ocp.s0) / n)
    scale = state_scale(problem)
    states = keep(X * scale)
    lam = costates(result.z, result.multipliers, ocp, grid)
    trajectory = Collocated(
        grid=grid, times=keep((node_s - ocp.s0) / n), dt_dtau=0.5 * duration + 0.0 * node_s,
        node_controls=keep(problem.acceleration * U), node_costates=keep(lam / (n * scale)),
        state_times=keep((rows_s - ocp.s0) / n), node_states=states, polynomial=states,
        s0=ocp.s0, sf=sf, magnitude=problem.acceleration, clock="uniform")
    return Solution(
        problem=problem, status=status, cost=duration, duration=duration,
        trajectory=trajectory,
        stats=keep(dict(node_s=node_s, state_s=rows_s, node_directions=U, costates_scaled=lam,
                        **_al_stats(result), **collocation_accuracy(problem, ocp, grid, X, U, sf)))
        | dict(duration_lower_bound=t_lb),
        method="augmented-lagrangian")


def _al_stats(result):
    """The augmented Lagrangian's own numbers (an `ALResult`), for the solution's stats."""
    return dict(multipliers=result.multipliers, path_multipliers=result.path_multipliers,
                constraint_residual=result.constraint_residual,
                path_residual=result.path_residual,
                stationarity_residual=result.stationarity_residual,
                complementarity=result.complementarity, outer_iterations=result.outer_iterations,
                inner_iterations=result.inner_iterations, history=result.history)


def anomaly_solution(problem: MinimumTimeTransfer, ocp, grid, result, status, valid, t_lb):
    """`to_solution` of `anomaly_min_time_ocp`: the duration t_f = t(s_f) by Kepler's equation,
    the trajectory on the true-anomaly clock (the chief's conic at the points), the states in
    LVLH (m, m/s), costates dJ/dx = (dx~/dx)^T (dphi/dx~) / n (J = t_f = phi / n, x~ =
    `energy_optimal.model_state`(x)), the error estimate that of the energy-optimal transfer of
    duration t_f flown with the renormalised interpolated direction
    (`energy_optimal.collocation_accuracy`); stats as `to_solution`'s, duration_lower_bound
    (s) that of HCW where the chief is circular on the linear model, else 0."""
    def keep(tree):
        return zero_invalid(valid, tree)

    o = problem.orbit
    X, U, sf = unpack(result.z, ocp, grid)
    rows_s, node_s = state_s(ocp, grid, sf), collocation_s(ocp, grid, sf)
    duration = time_from_true_anomaly(o, sf)
    chief = kepler_chief(o, rows_s)
    states = jax.vmap(lambda x, s: lvlh_state(problem, x, s))(X, rows_s)
    lam = costates(result.z, result.multipliers, ocp, grid)
    node_costates = jax.vmap(
        lambda p, s: jax.vjp(lambda x: model_state(problem, x, s), jnp.zeros(6))[1](p)[0])(
            lam, node_s) / o.mean_motion
    rows = collocated_rows(grid)
    trajectory = Collocated(
        grid=grid, times=chief.t[rows],
        dt_dtau=0.5 * (sf - ocp.s0) / jax.vmap(anomaly_rate)(chief.state[rows]),
        node_controls=keep(problem.acceleration * U), node_costates=keep(node_costates),
        state_times=keep(chief.t), node_states=keep(states), polynomial=keep(states),
        s0=ocp.s0, sf=sf, orbit=o, magnitude=problem.acceleration, clock="true-anomaly")
    twin = EnergyOptimalTransfer(o, problem.x0, problem.xf, duration, model=problem.model,
                                 j2=problem.j2, r_eq=problem.r_eq)
    a = ocp.params["accel"]
    accuracy = energy_accuracy(twin, grid, X, a * U, s_f=sf,
                               control_map=lambda u: a * unit_direction(u))
    return Solution(
        problem=problem, status=status, cost=keep(duration), duration=keep(duration),
        trajectory=trajectory,
        stats=keep(dict(node_s=node_s, state_s=rows_s, node_directions=U, costates_scaled=lam,
                        **_al_stats(result), **accuracy))
        | dict(duration_lower_bound=t_lb),
        method="augmented-lagrangian")
