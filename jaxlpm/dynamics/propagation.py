"""The one place jaxlpm integrates ODEs: `solve_ode` (the non-raising diffrax call every
integrator goes through), the integrator settings each use is given (`Integrator`, defined
once here), and the coast propagation of one inertial state under two-body + J2 gravity
(`propagate`, `gravity.inertial_rhs`).

Every integration runs on states scaled to O(1) by its caller, with diffrax's PID step
control:
  COAST         Dopri8, rtol = atol = 1e-12: `propagate` on the state scaled by |r0| and
                |r0| sqrt(mu / |r0|^3), so positions are held to ~1e-12 |r0| per unit step
                error: millimetres at 4e7 m, over the days of coast of a long-range intercept
                (tests/test_propagation.py measures it against scipy's DOP853); also the
                relative flights of `jaxlpm.verify` (200 000 steps for long transfers).
  EPHEMERIS     Dopri8, 1e-13: the J2 chief sampled for the transcription, the indirect
                (shooting) references, and the impulsive intercept's error estimate (its
                coasts again), one decade tighter than the solutions they check.
  INDEPENDENT   Tsit5, 1e-13: the inertial truth flight of `jaxlpm.verify`, which shares no
                integration choice with the solvers' Dopri8.
  VARIATIONAL   Dopri8, 1e-9: second-order variational equations that only shape a
                boundary model's curvature (they set a convergence rate, not a result).
  COAST_TANGENT COAST in forward mode: a coast's end state and its Jacobian in the
                initial state from one `jax.jacfwd` pass (a finite burn's terminal model).
Differentiable in reverse mode (diffrax's recursive checkpointing adjoint) unless an
`Integrator` says otherwise; `j2 = 0` gives exactly two-body. SI units: m, m/s, s.
"""

import contextlib
import importlib
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from .._validation import check_finite, check_shape, is_concrete, require_x64
from ..constants import J2_EARTH, MU_EARTH, R_EARTH
from ..status import Status
from .gravity import inertial_rhs



@dataclass(frozen=True)
class Integrator:
    """Settings of one use of `solve_ode` (hashable: a static argument)."""

    rtol: float
    atol: float
    max_steps: int = 100_000
    solver: str = "Dopri8"          # a diffrax solver class name
    adjoint: str = "RecursiveCheckpointAdjoint"


COAST = Integrator(1e-12, 1e-12)
FLIGHT = Integrator(1e-12, 1e-12, max_steps=200_000)
EPHEMERIS = Integrator(1e-13, 1e-13)
SHOOTING = Integrator(1e-13, 1e-13, adjoint="ForwardMode")
INDEPENDENT = Integrator(1e-13, 1e-13, max_steps=1_000_000, solver="Tsit5")
VARIATIONAL = Integrator(1e-9, 1e-9)
COAST_TANGENT = Integrator(1e-12, 1e-12, adjoint="ForwardMode")


def _all_finite(tree):
    leaves = jax.tree_util.tree_leaves(tree)
    return jnp.all(jnp.stack([jnp.all(jnp.isfinite(x)) for x in leaves]))


@contextlib.contextmanager
def _runtime_checks_as_nan():
    """Trace diffrax with equinox's runtime checks (`eqx.error_if`: e.g. saveat times out of
    order) returning NaN instead of raising through a host callback, where the user has not
    chosen otherwise (EQX_ON_ERROR unset, i.e. "raise"). `solve_ode` never raises: a NaN
    becomes its NONFINITE status. A program without host callbacks is also one that JAX's
    persistent cache and `jaxlpm.compilation` can keep on disk (issue 21: the flights and
    the J2 transfers were compiled again on every run). equinox reads the mode from its
    module `equinox._errors` when a check is traced; if that attribute is gone, nothing
    changes."""
    errors = importlib.import_module("equinox._errors")
    if getattr(errors, "EQX_ON_ERROR", None) != "raise":
        yield
        return
    errors.EQX_ON_ERROR = "nan"
    try:
        yield
    finally:
        errors.EQX_ON_ERROR = "raise"


def solve_ode(rhs, y0, t0, t1, ts, integrator: Integrator, step_ts=None):
    """Integrate dy/dt = rhs(t, y) (y any pytree) from t0 to t1 with PID-controlled adaptive
    steps (dt0 chosen by diffrax) and the `integrator`'s settings; never raises (diffrax
    throw=False), also under jit/vmap. step_ts: times in (t0, t1) that the steps land on
    (diffrax's `ClipStepSizeController`), one inside each piece of a piecewise control: an
    adaptive step grown over a coast would otherwise step over a burn shorter than itself
    unseen (a step to the piece's break itself, or diffrax's jump_ts, would evaluate a
    control of the chief's integrated anomaly on either side of its jump there).

    Returns (ys at the times `ts`, or with ts None at t1 alone (a leading axis of 1), status
    int32): SUCCESS; MAX_ITERATIONS when max_steps ran out
    (ys: the last accepted state at t1, inf at save times not reached); NONFINITE for any
    other diffrax failure, non-finite saved states, or a non-finite t1 - t0, y0 or
    rhs(t0, y0). In that last case the solve is skipped (y' = 0 from y = 0: a few steps, not
    max_steps rejected ones, so one bad member does not stall a vmapped batch) and ys are
    zeros.
    """
    # imported here, the one module that calls it: diffrax (with equinox, lineax and
    # optimistix) takes 0.45 s to import, which a run whose programs load from disk
    # (`jaxlpm.compilation`) never needs
    import diffrax

    bad = ~(jnp.isfinite(t1 - t0) & _all_finite(y0) & _all_finite(rhs(t0, y0)))
    blank = lambda tree: jax.tree_util.tree_map(lambda x: jnp.where(bad, 0.0, x), tree)
    with _runtime_checks_as_nan():
        sol = diffrax.diffeqsolve(
            diffrax.ODETerm(lambda t, y, args: blank(rhs(t, y))),
            getattr(diffrax, integrator.solver)(), t0, t1, dt0=None, y0=blank(y0),
            saveat=diffrax.SaveAt(t1=True) if ts is None else diffrax.SaveAt(ts=ts),
            max_steps=integrator.max_steps,
            stepsize_controller=_controller(diffrax, integrator, step_ts),
            adjoint=getattr(diffrax, integrator.adjoint)(), throw=False)
    success = (sol.result == diffrax.RESULTS.successful) & _all_finite(sol.ys)
    out_of_steps = sol.result == diffrax.RESULTS.max_steps_reached
    status = jnp.select([bad, success, out_of_steps],
                        [Status.NONFINITE, Status.SUCCESS, Status.MAX_ITERATIONS],
                        Status.NONFINITE)
    return sol.ys, status.astype(jnp.int32)


def _controller(diffrax, integrator: Integrator, step_ts):
    pid = diffrax.PIDController(rtol=integrator.rtol, atol=integrator.atol)
    if step_ts is None or jnp.size(step_ts) == 0:
        return pid
    return diffrax.ClipStepSizeController(pid, step_ts=step_ts)


def _scales(state, mu):
    length = jnp.linalg.norm(state[:3])
    return jnp.concatenate([jnp.full(3, length), jnp.full(3, jnp.sqrt(mu / length))])


def _check_propagation(state, duration, mu, j2, r_eq):
    require_x64()
    check_shape("state", state, (6,))
    for name, value in (("duration", duration), ("mu", mu), ("j2", j2), ("r_eq", r_eq)):
        check_shape(name, value, ())
    if not is_concrete(state, duration, mu, j2, r_eq):
        return
    r = check_finite("state", state)[:3]
    for name, value in (("duration", duration), ("j2", j2)):
        check_finite(name, value)
    if not np.linalg.norm(r) > 0.0:
        raise ValueError("state must have a non-zero position (m)")
    for name, value in (("mu", mu), ("r_eq", r_eq)):
        if not float(check_finite(name, value)) > 0.0:
            raise ValueError(f"{name} must be positive, got {value}")


def propagate(state, duration, mu=MU_EARTH, j2=J2_EARTH, r_eq=R_EARTH, ts=None,
              integrator: Integrator = COAST):
    """Coast `state` = [r (m), v (m/s)] for `duration` (s, > 0; negative integrates backwards)
    with the `integrator`'s settings (default COAST).

    Returns (final state (6,), ok) or, with `ts` (times in [0, duration], s), (states
    (len(ts), 6), ok); ok is False when the integration failed (`solve_ode`: step limit,
    non-finite input or states). Concrete bad input (shapes, types, non-finite values, a
    zero position, mu or r_eq <= 0) raises ValueError; traced bad input gives ok = False.
    """
    _check_propagation(state, duration, mu, j2, r_eq)
    state = jnp.asarray(state, dtype=jnp.float64)
    scale = _scales(state, mu)
    ys, status = solve_ode(
        lambda t, y: inertial_rhs(y * scale, jnp.zeros(3), mu, j2, r_eq) / scale,
        state / scale, 0.0, duration, ts, integrator)
    ys = ys * scale
    valid = (jnp.isfinite(mu) & (mu > 0.0) & jnp.isfinite(r_eq) & (r_eq > 0.0)
             & jnp.isfinite(j2))            # the checks of `_check_propagation`, traced
    return (ys[-1] if ts is None else ys), (status == Status.SUCCESS) & valid
