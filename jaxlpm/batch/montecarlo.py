"""Monte Carlo studies of any problem family, each reproducible from a `jax.random` key.

(a) `replan_monte_carlo`: re-plan per sample. The user's dispersion function draws one
    batched problem of any family (a case's own, e.g. `jaxlpm.cases.mei2010.dispersion`, or
    a research script's), solved member by member by the sweep engine (chunked, sharded,
    resumable), one row per sample.
(b) `execution_monte_carlo`: one plan (any LVLH `Solution`), flown many times through a truth
    model (the plan's own by default, as `jaxlpm.verify.fly`; "linear", "two-body" or "j2" on
    request) with execution errors drawn per sample:
      thrust magnitude   u -> (1 + d_mag) u,            d_mag ~ N(0, magnitude^2)
      thrust direction   u -> R(axis, angle) u,         axis uniform on the sphere,
                                                        angle ~ N(0, direction^2) (rad)
      navigation         true x0 = planned x0 + (dr, dv), dr ~ N(0, position^2 I3) (m),
                                                        dv ~ N(0, velocity^2 I3) (m/s)
    (a constant bias of the engine over the whole transfer, and an initial state known to the
    navigation filter's accuracy), measuring the terminal miss against the plan's target.

Statistics are taken over the SUCCESS samples only (`converged_statistics`); the others are
counted and listed.
"""

import functools
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from .._validation import require_x64
from ..collocation import lgl
from ..status import Status
from ..verify.fly import flight_model, propagate_linear, propagate_nonlinear, step_times
from ..mapping import map_in_groups
from .family import SweepFamily, problem_table, solution_record
from .sweep import PERCENTILES, converged_statistics, sweep


def _name(fn) -> str:
    """module.qualname of a function (of the function a functools.partial wraps)."""
    while isinstance(fn, functools.partial):
        fn = fn.func
    return f"{getattr(fn, '__module__', '')}.{getattr(fn, '__qualname__', type(fn).__name__)}"


def replan_monte_carlo(key, n: int, dispersion, points, *, grid=lgl, method=None,
                       options=None, record=solution_record, out=None, chunk_size: int = 256,
                       name: str = "replan", **sweep_options):
    """Re-plan `n` dispersed problems of any family: `dispersion(key, n)` returns ONE batched
    problem (every array leaf with the n samples on its leading axis; scalar leaves are
    shared), e.g.

        def dispersion(key, n):
            return jax.vmap(lambda k: MinimumTimeTransfer(orbit, x0 + 100.0 * jax.random.normal(
                k, (6,)), xf, thrust, mass))(jax.random.split(key, n))

    or a case's own (`jaxlpm.cases.mei2010.dispersion`, with functools.partial for its
    model). Each sample is solved by `jaxlpm.solve(problem, grid(points), method=method,
    options=options)` at every point count of `points` and recorded by `record` (default
    `solution_record`: status, cost, delta_v, duration and the solver's scalar stats).

    Returns the `SweepResult`: one row per sample with its problem's leaves
    ("problem.orbit.e", "problem.x0", ...; `problem_table`) and its record;
    `.statistics()` gives cost and delta-v statistics over the SUCCESS samples and lists the
    others (`.summary()` counts them by status). `sweep_options` go to `sweep` (batch_size,
    progress, ...). The draw (its parameters' SHA-256, the key, the dispersion's name) is part
    of the sweep's definition, so `out` resumes only the same draw.
    """
    require_x64()
    n = int(n)
    if n < 1:
        raise ValueError(f"n must be a positive number of samples, got {n}")
    problems = dispersion(key, n)
    params, build = problem_table(problems)
    drawn = next(iter(params.values())).shape[0]
    if drawn != n:
        raise ValueError(f"dispersion(key, {n}) must return {n} problems (the leading axis of "
                         f"every leaf), got {drawn}")
    family = SweepFamily(name=name, build=build, grid=grid, method=method, options=options,
                         record=record, definition=dict(
                             problem=type(problems).__name__, dispersion=_name(dispersion),
                             n=n, key=np.asarray(jax.random.key_data(key)).tolist(),
                             grid=_name(grid), record=_name(record)))
    return sweep(family, params, points, out, chunk_size=chunk_size, **sweep_options)


@dataclass(frozen=True)
class ExecutionErrors:
    """One-sigma execution errors: thrust magnitude (relative), thrust direction (rad),
    navigation position (m per axis) and velocity (m/s per axis); each finite and >= 0."""

    magnitude: float = 0.0
    direction: float = 0.0
    position: float = 0.0
    velocity: float = 0.0

    def __post_init__(self):
        for name in ("magnitude", "direction", "position", "velocity"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0.0):
                raise ValueError(f"ExecutionErrors.{name} is a standard deviation: finite and "
                                 f">= 0, got {value!r}")


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class _ErroneousControl:
    """u(x) = gain * rotation @ planned u(x) (x: the planned control's variable)."""

    planned: object
    gain: jax.Array
    rotation: jax.Array

    @property
    def variable(self):
        return self.planned.variable

    def __call__(self, x):
        return self.gain * (self.rotation @ self.planned(x))


def _rotation(axis, angle):
    """Rodrigues: rotation by `angle` (rad) about the unit vector `axis`."""
    K = jnp.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]],
                   [-axis[1], axis[0], 0.0]])
    return jnp.eye(3) + jnp.sin(angle) * K + (1.0 - jnp.cos(angle)) * (K @ K)


def execution_draws(key, n: int, errors: ExecutionErrors) -> dict:
    """The n samples' errors (see the module docstring): gain (n,), axis (n, 3), angle (n,),
    dx0 (n, 6). One split of `key` per quantity (order: magnitude, axis, angle, position,
    velocity)."""
    k_m, k_a, k_t, k_r, k_v = jax.random.split(key, 5)
    f64 = jnp.float64
    axis = jax.random.normal(k_a, (n, 3), f64)
    return dict(gain=1.0 + errors.magnitude * jax.random.normal(k_m, (n,), f64),
                axis=axis / jnp.linalg.norm(axis, axis=1, keepdims=True),
                angle=errors.direction * jax.random.normal(k_t, (n,), f64),
                dx0=jnp.concatenate([errors.position * jax.random.normal(k_r, (n, 3), f64),
                                     errors.velocity * jax.random.normal(k_v, (n, 3), f64)], 1))


def _fly(d, control, problem, duration, model, j2, r_eq, steps):
    """One sample: the planned control with its errors, from the erroneous initial state."""
    u = _ErroneousControl(control, d["gain"], _rotation(d["axis"], d["angle"]))
    x0 = problem.x0 + d["dx0"]
    if model == "linear":
        _, xs, status = propagate_linear(problem.orbit, x0, duration, u, n_save=2,
                                         steps=steps)
    else:
        _, xs, status = propagate_nonlinear(problem.orbit, x0, duration, u, n_save=2, j2=j2,
                                            r_eq=r_eq, steps=steps)
    ok = status == Status.SUCCESS
    miss = xs[-1] - problem.xf
    return dict(final_state=xs[-1], position_miss=jnp.linalg.norm(miss[:3]),
                velocity_miss=jnp.linalg.norm(miss[3:]),
                status=jnp.where(ok & jnp.all(jnp.isfinite(xs[-1])), Status.SUCCESS,
                                 jnp.where(ok, Status.NONFINITE, status)).astype(jnp.int32))


@functools.partial(jax.jit, static_argnames=("model", "batch_size"))
def _fly_all(draws, control, problem, duration, j2, r_eq, model, batch_size, steps=None):
    """The error-free flight (row 0) and every sample's, through one traced integrator (the
    nominal rides in the batch); one compile per (model, control kind, batch size, sample
    count), whatever the plan's grid size (the control is padded to a fixed size)."""
    nominal = dict(gain=jnp.ones(1), axis=jnp.array([[0.0, 0.0, 1.0]]), angle=jnp.zeros(1),
                   dx0=jnp.zeros((1, 6)))
    rows = jax.tree_util.tree_map(lambda a, b: jnp.concatenate([a, b]), nominal, draws)
    return map_in_groups(lambda d: _fly(d, control, problem, duration, model, j2, r_eq, steps),
                         rows, batch_size)


def execution_monte_carlo(key, plan, n: int, errors: ExecutionErrors, model: str | None = None,
                          batch_size: int = 64, percentiles=PERCENTILES) -> dict:
    """Fly `plan` (an unbatched LVLH `Solution` of any family: its control as the propagator
    calls it, `plan.trajectory.flight_control()`, over the plan's duration) `n` times through
    `model` (None: the plan's own, as `jaxlpm.verify.fly`; "linear": the linearised elliptic
    equations; "two-body"; "j2", with the problem's j2 and r_eq) with execution errors drawn
    from `key`.

    Returns a dict of NumPy arrays and statistics: model, the draws (gain, axis, angle, dx0),
    final_state (n, 6) LVLH, position_miss (m) and velocity_miss (m/s) against the problem's
    target xf, status (SUCCESS, or the integrator's failure: MAX_ITERATIONS, NONFINITE),
    nominal (the error-free flight's [position, velocity] miss), nominal_final_state, and
    statistics of both misses over the successful samples. Samples run `batch_size` at a time
    (vmap inside lax.map).
    """
    require_x64()
    if plan.frame != "LVLH" or np.ndim(plan.status) != 0:
        raise ValueError(f"plan must be one (unbatched) LVLH Solution, got a {plan.frame} "
                         f"solution with status shape {np.shape(plan.status)}")
    problem = plan.problem
    model, j2, r_eq = flight_model(problem, model)
    if int(n) < 1:
        raise ValueError(f"n must be a positive number of samples, got {n}")
    draws = execution_draws(key, int(n), errors)
    rows = _fly_all(draws, plan.trajectory.flight_control(), problem, plan.duration, j2, r_eq,
                    model, min(int(batch_size), int(n) + 1), step_times(plan.trajectory))
    rows = {k: np.asarray(v) for k, v in rows.items()}
    out = {**{k: np.asarray(v) for k, v in draws.items()}, **{k: v[1:] for k, v in rows.items()}}
    out["model"] = model
    out["nominal"] = np.array([rows["position_miss"][0], rows["velocity_miss"][0]])
    out["nominal_final_state"] = rows["final_state"][0]
    out["statistics"] = {k: converged_statistics(out[k], out["status"], percentiles)
                         for k in ("position_miss", "velocity_miss")}
    return out
