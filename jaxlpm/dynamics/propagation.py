"""Coast propagation of one inertial state under two-body + J2 gravity (`gravity.inertial_rhs`).

Integrator: diffrax Dopri8 (8th-order Dormand-Prince, adaptive, PID step control) at
rtol = atol = 1e-12 on the state scaled by |r0| and |r0| sqrt(mu / |r0|^3), so positions are
held to ~1e-12 |r0| per unit step error: millimetres at 4e7 m, over the days of coast of a
long-range intercept (tests/test_propagation.py measures it against scipy's DOP853).
Differentiable in reverse mode (diffrax's recursive checkpointing adjoint); `j2 = 0` gives
exactly two-body. SI units: m, m/s, s.
"""

import diffrax
import jax.numpy as jnp

from ..constants import J2_EARTH, MU_EARTH, R_EARTH
from .gravity import inertial_rhs

RTOL = ATOL = 1e-12
MAX_STEPS = 100_000


def _scales(state, mu):
    length = jnp.linalg.norm(state[:3])
    return jnp.concatenate([jnp.full(3, length), jnp.full(3, jnp.sqrt(mu / length))])


def propagate(state, duration, mu=MU_EARTH, j2=J2_EARTH, r_eq=R_EARTH, ts=None):
    """Coast `state` = [r (m), v (m/s)] for `duration` (s, > 0; negative integrates backwards).

    Returns (final state (6,), ok) or, with `ts` (times in [0, duration], s), (states
    (len(ts), 6), ok); ok is False when diffrax did not finish (step limit or non-finite).
    """
    state = jnp.asarray(state, dtype=jnp.float64)
    scale = _scales(state, mu)
    term = diffrax.ODETerm(
        lambda t, y, args: inertial_rhs(y * scale, jnp.zeros(3), mu, j2, r_eq) / scale)
    saveat = diffrax.SaveAt(t1=True) if ts is None else diffrax.SaveAt(ts=ts)
    sol = diffrax.diffeqsolve(
        term, diffrax.Dopri8(), 0.0, duration, dt0=None, y0=state / scale, saveat=saveat,
        stepsize_controller=diffrax.PIDController(rtol=RTOL, atol=ATOL), max_steps=MAX_STEPS,
        throw=False)
    ys = sol.ys * scale
    return (ys[-1] if ts is None else ys), sol.result == diffrax.RESULTS.successful

