"""Fly a solution: propagate its interpolated control through a dynamics model with a tight
integrator, independently of the grid it was solved on, and measure where it arrives.

`fly(solution, model=None)` flies a relative transfer (frame LVLH) from its problem's x0 for
its duration on its own model by default ("linear" for the HCW families; the problem's
`model` for energy-optimal transfers) or on the one named, and returns a `Flight`: the
trajectory, its terminal error against the problem's target xf, its largest deviation from the
solution's own states, and a status (never an exception: a failed integration is status
MAX_ITERATIONS or NONFINITE).

Models (SI; LVLH: x radial outward, y along-track, z orbit normal):
  "linear"    the linearised elliptic LVLH equations in time (Yamanaka-Ankersen eq. 2; HCW
              for a circular chief), the chief's true anomaly integrated beside the state;
  "two-body", "j2"  chief and deputy integrated inertially (the deputy as its exact offset
              from the chief) under two-body gravity, plus J2 on both for "j2", differenced in
              the chief's LVLH frame; the chief's regularised anomaly d/dt = |h| / r^2
              integrated beside them (the true anomaly of a Keplerian chief).
A control collocated in the chief's anomaly is applied at the flight chief's anomaly; one
collocated in time (the HCW families), at the time. Integrator: `FLIGHT` (Dopri8,
rtol = atol = 1e-12 on scaled states; `jaxlpm.dynamics.propagation`).

An intercept (frame "inertial": `ImpulsiveIntercept`, `FiniteBurnIntercept`) is flown by the
independent inertial integrator (`jaxlpm.verify.inertial.fly_burn`: Tsit5, `INDEPENDENT`)
from its initial state at t = 0 through the solution's burn (the impulse, or the engine along
the renormalised interpolated direction with the mass as a state) to t_f, on model "j2" (the
problem's mu, j2, r_eq; the default) or "two-body" (j2 = 0). Its terminal error is
[|r(t_f) - r_target| (m), 0]: the velocity at t_f is free, so the second entry is 0; its
states are [r, v] (the mass is integrated but not returned) and a failed flight is status
NONFINITE.
"""

from dataclasses import dataclass, field

import jax
import jax.numpy as jnp
import numpy as np

from ..compilation import compiled
from .._validation import is_concrete, require_x64
from ..collocation import Grid
from ..constants import J2_EARTH, R_EARTH
from ..dynamics import elliptic_lvlh_rhs, gravity_acceleration, relative_inertial_rhs
from ..dynamics.chief import anomaly_rate
from ..dynamics.propagation import FLIGHT, solve_ode
from ..orbits import elements_to_state, lvlh_to_relative_inertial, relative_inertial_to_lvlh
from ..solution import Collocated, FiniteBurn
from ..status import Status
from .inertial import fly_burn

MODELS = ("linear", "two-body", "j2")
INERTIAL_MODELS = ("two-body", "j2")
N_SAVE = 401


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class Flight:
    """A flown solution (SI, the solution's frame).

    times           (n_save,) s since the start, uniform over the duration
    states          (n_save, 6) the flown states (m, m/s)
    terminal_error  (2,) [|position error| (m), |velocity error| (m/s)] of the final state
                    against the problem's target
    plan_error      (2,) the largest [position (m), velocity (m/s)] difference between the
                    flown and the solution's own states over `times`: how far the transcribed
                    solution is from the flow of its own control
    status          `Status`: SUCCESS, or the integrator's failure (MAX_ITERATIONS: out of
                    steps; NONFINITE)
    model           the model flown (static)
    """

    times: jax.Array
    states: jax.Array
    terminal_error: jax.Array
    plan_error: jax.Array
    status: jax.Array
    model: str = field(default="linear", metadata=dict(static=True))

    @property
    def success(self):
        return self.status == Status.SUCCESS


def _control_at(control, t, anomaly):
    return control(anomaly if control.variable == "anomaly" else t)


def _state_scale(x0, orbit):
    """Length scale max(|r0|, 1 m) and its velocity scale n * length, for scaled integration."""
    length = jnp.maximum(jnp.linalg.norm(x0[:3]), 1.0)
    return jnp.concatenate([jnp.full(3, length), jnp.full(3, length * orbit.mean_motion)])


def _integrate(rhs, y0, scale, duration, n_save, steps=None):
    """dy/dt = rhs(t, y) from 0 to duration in y / scale, saved at n_save uniform times:
    (times, ys, status), never raising (`solve_ode`; steps: its step_ts)."""
    ts = jnp.linspace(0.0, 1.0, n_save) * duration
    ys, status = solve_ode(lambda t, y: rhs(t, y * scale) / scale, y0 / scale, 0.0, duration,
                           ts, FLIGHT, steps)
    return ts, ys * scale, status


def propagate_linear(orbit, x0, duration, control, n_save: int = N_SAVE, steps=None):
    """Fly `control` (a `jaxlpm.solution` control: of time or of the chief's anomaly, m/s^2)
    through the linearised elliptic LVLH equations in time. x0 (m, m/s) at the orbit's epoch;
    steps: times (s) the integrator steps to (`Collocated.step_times`), or None.
    Returns (times (n_save,), LVLH states (n_save, 6), status)."""
    require_x64()
    e, k2, p, mu = orbit.e, orbit.k2, orbit.p, orbit.mu

    def rhs(t, y):
        f = y[6]
        u = _control_at(control, t, f)
        return jnp.concatenate([elliptic_lvlh_rhs(f, y[:6], u, e, k2, p, mu),
                                (k2 * (1.0 + e * jnp.cos(f)) ** 2)[None]])

    y0 = jnp.concatenate([x0, jnp.atleast_1d(orbit.f0 + 0.0 * e)])
    scale = jnp.concatenate([_state_scale(x0, orbit), jnp.ones(1)])
    ts, ys, status = _integrate(rhs, y0, scale, duration, n_save, steps)
    return ts, ys[:, :6], status


def propagate_nonlinear(orbit, x0, duration, control, n_save: int = N_SAVE, j2=0.0,
                        r_eq=R_EARTH, steps=None):
    """Fly `control` through exact relative motion (two-body, plus J2 on both spacecraft when
    j2 != 0); the chief starts on `orbit`'s state at its epoch, x0 (m, m/s) LVLH; steps as
    `propagate_linear` takes them. Returns (times (n_save,), LVLH states (n_save, 6),
    status)."""
    require_x64()
    mu = orbit.mu
    rc, vc = elements_to_state(orbit)
    a_chief = gravity_acceleration(rc, mu, j2, r_eq)
    dr, dv = lvlh_to_relative_inertial(rc, vc, x0, a_chief)

    def rhs(t, y):
        u = _control_at(control, t, y[12])
        rate = relative_inertial_rhs(y[:12], u, mu, j2, r_eq)
        return jnp.concatenate([rate, anomaly_rate(y[:6])[None]])

    y0 = jnp.concatenate([rc, vc, dr, dv, jnp.atleast_1d(orbit.f0 + 0.0 * orbit.e)])
    scale = jnp.concatenate([jnp.full(3, orbit.a), jnp.full(3, orbit.a * orbit.mean_motion),
                             _state_scale(x0, orbit), jnp.ones(1)])
    ts, ys, status = _integrate(rhs, y0, scale, duration, n_save, steps)

    def to_lvlh(y):
        acc = gravity_acceleration(y[:3], mu, j2, r_eq)
        return relative_inertial_to_lvlh(y[:3], y[3:6], y[6:9], y[9:12], acc)

    return ts, jax.vmap(to_lvlh)(ys), status


def terminal_error(states, target):
    """[|position error| (m), |velocity error| (m/s)] of the final state against the target."""
    d = states[-1] - target
    return jnp.stack([jnp.linalg.norm(d[:3]), jnp.linalg.norm(d[3:])])


def _largest_difference(a, b):
    d = a - b
    return jnp.stack([jnp.max(jnp.linalg.norm(d[:, :3], axis=1)),
                      jnp.max(jnp.linalg.norm(d[:, 3:], axis=1))])


@compiled(static_argnames=("linear", "n_save"))
def _fly_lvlh(orbit, x0, xf, duration, control, j2, r_eq, linear, n_save, steps=None):
    """One flight: (times, states, terminal error, status). `control` is padded, so this
    compiles once per (linear or not, n_save, control kind), whatever the grid's size (a
    `Mesh`'s control and steps: once per mesh shape); j2 = 0 is the two-body model."""
    if linear:
        ts, xs, status = propagate_linear(orbit, x0, duration, control, n_save, steps)
    else:
        ts, xs, status = propagate_nonlinear(orbit, x0, duration, control, n_save, j2, r_eq,
                                             steps)
    return ts, xs, terminal_error(xs, xf), status


@compiled
def _plan_difference(solution, ts, xs):
    """The largest distance between the flown states xs and the solution's at ts."""
    return _largest_difference(xs, solution.states(ts))


def _plan(solution):
    """The solution whose states `_plan_difference` evaluates: a concrete one reduced to
    what evaluating it reads (`Solution.evaluable`), and on an LGL `Grid` with its
    trajectory padded (`Collocated.padded`, `FiniteBurn.padded`), so that one program serves
    every grid, method and problem up to the capacity (mei2010 flies 16 solutions of 2 laws
    on 7 grids, tan2011 burns on 3 grids)."""
    tr = solution.trajectory
    if not (is_concrete(solution) and jnp.ndim(solution.status) == 0):
        return solution
    if (isinstance(tr, (Collocated, FiniteBurn)) and type(tr.grid) is Grid
            and tr.grid.scheme == "LGL"):
        tr = tr.padded()
    return solution.replace(trajectory=tr).evaluable()


def step_times(trajectory):
    """The times (s) a flight of the trajectory's control steps to (`Collocated.step_times`:
    the middles of a `Mesh`'s segments), or None."""
    return trajectory.step_times() if isinstance(trajectory, Collocated) else None


def default_model(problem) -> str:
    """The model a problem's solution is flown on by default: its own (`model`), "linear"
    for the families without one (HCW: the linear model of a circular chief)."""
    return getattr(problem, "model", "linear")


def flight_model(problem, model: str | None):
    """(model, j2, r_eq) a relative flight of `problem` uses: `model` (None: the problem's
    own, `default_model`), the problem's J2 coefficient on the "j2" model (else 0) and its
    equatorial radius (m; the library's constants for a problem without them)."""
    model = default_model(problem) if model is None else model
    if model not in MODELS:
        raise ValueError(f"model must be one of {MODELS}, got {model!r}")
    j2 = jnp.asarray(getattr(problem, "j2", J2_EARTH) if model == "j2" else 0.0, jnp.float64)
    return model, j2, jnp.asarray(getattr(problem, "r_eq", R_EARTH), jnp.float64)


def fly(solution, model: str | None = None, n_save: int = N_SAVE) -> Flight:
    """Fly `solution` (a relative transfer, frame LVLH, or an intercept, frame inertial;
    module docstring) on `model` (None: its own), saving n_save uniform times; a batched
    solution flies member by member (its leading axes on every output). Returns a `Flight`;
    never raises for a failed integration (its status says so)."""
    require_x64()
    if isinstance(n_save, bool) or not isinstance(n_save, int) or n_save < 2:
        raise ValueError(f"n_save must be an integer >= 2, got {n_save!r}")
    if solution.frame == "inertial":
        return _fly_inertial(solution, "j2" if model is None else model, n_save)
    if solution.frame != "LVLH":
        raise ValueError(f"fly flies relative (LVLH) transfers and intercepts (inertial), got "
                         f"a solution in the {solution.frame!r} frame")
    model, j2, r_eq = flight_model(solution.problem, model)

    def one(sol, j2, r_eq):
        p = sol.problem
        tr = sol.trajectory
        ts, xs, err, status = _fly_lvlh(p.orbit, p.x0, p.xf, sol.duration,
                                        tr.flight_control(), j2, r_eq, model == "linear",
                                        n_save, step_times(tr))
        return Flight(ts, xs, err, _plan_difference(_plan(sol), ts, xs), status,
                      model)

    for _ in range(jnp.ndim(solution.status)):
        one = jax.vmap(one)
    j2, r_eq = (jnp.broadcast_to(x, jnp.shape(solution.status)) for x in (j2, r_eq))
    return one(solution, j2, r_eq)


_fly_burn = compiled(fly_burn)
"""`fly_burn` compiled once per burn kind (impulse or engine, its direction padded by
`jaxlpm.solution.control_interpolant`) and number of samples, whatever the grid's size; the
program a script that samples a burn with `compiled(fly_burn)` at as many times also runs."""


def _fly_intercept(solution, j2, n_save):
    """One intercept flight: (times, [r, v] states, terminal error, status); the flight by
    `_fly_burn`, the rest on the host where nothing is traced."""
    tr = solution.trajectory
    xp = np if is_concrete(solution) else jnp
    ts = xp.linspace(0.0, 1.0, n_save) * xp.asarray(solution.duration)
    ys, ok = _fly_burn(tr.state0, tr.burn(), solution.duration, ts, tr.mu, j2, tr.r_eq)
    xs = xp.asarray(ys)[:, :6]
    miss = xp.linalg.norm(xs[-1, :3] - xp.asarray(solution.problem.r_target))
    status = xp.where(xp.asarray(ok), Status.SUCCESS, Status.NONFINITE).astype(xp.int32)
    return (jnp.asarray(ts), jnp.asarray(xs), jnp.asarray(xp.stack([miss, 0.0 * miss])),
            jnp.asarray(status))


def _fly_inertial(solution, model, n_save) -> Flight:
    """`fly` for an intercept (module docstring), member by member when batched."""
    if model not in INERTIAL_MODELS:
        raise ValueError(f"model must be one of {INERTIAL_MODELS} for an intercept, got "
                         f"{model!r}")

    def one(sol):
        j2 = sol.trajectory.j2 if model == "j2" else jnp.zeros_like(sol.trajectory.j2)
        ts, xs, err, status = _fly_intercept(sol, j2, n_save)
        return Flight(ts, xs, err, _plan_difference(_plan(sol), ts, xs), status, model)

    for _ in range(jnp.ndim(solution.status)):
        one = jax.vmap(one)
    return one(solution)
