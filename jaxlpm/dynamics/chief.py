"""The chief's trajectory sampled in its regularised anomaly s, ds/dt = |h| / r^2.

For a Keplerian chief s is the true anomaly f (f_dot = |h| / r^2) and the samples are
analytic. For a J2-perturbed chief s = f0 + int_0^t |h| / r^2 dt is the regularised variable the
eccentric-orbit problems are collocated in (it advances like an argument of latitude: one orbit
per 2 pi, fast at perigee, so orbital harmonics stay low-degree polynomials in s). Its samples
come from two integrations (`jaxlpm.dynamics.propagation.EPHEMERIS`: Dopri8, rtol = atol = 1e-13 in scaled
variables), each over a
normalised interval [0, 1] so that the duration and the final anomaly enter as parameters and
everything is differentiable (also with respect to J2):

    1. in time, t = T sigma:              d[r, v, s]/dsigma = T [v, a(r), |h|/r^2]  -> s_f
    2. in s, s = f0 + (s_f - f0) sigma:   d[r, v, t]/dsigma = (s_f - f0) r^2/|h| [v, a(r), 1]

saving pass 2 at the requested sigma. a = two-body + J2 (`gravity_acceleration`), SI units.
Both return ok = False instead of raising when the integration fails (`solve_ode`: the step
limit over thousands of revolutions, or a non-finite orbit under vmap).
"""

from dataclasses import dataclass

import jax
import jax.numpy as jnp

from ..orbits import (KeplerOrbit, elements_to_state, time_from_true_anomaly,
                      true_anomaly_from_time)
from ..status import Status
from .gravity import gravity_acceleration
from .propagation import EPHEMERIS, solve_ode


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class ChiefSamples:
    """The chief at anomalies s (rad): times t since the epoch (s), inertial [r, v] (m, m/s)."""

    s: jax.Array
    t: jax.Array
    state: jax.Array


def anomaly_rate(state):
    """ds/dt = |r x v| / |r|^2 (rad/s) for an inertial state [r, v]."""
    r, v = state[:3], state[3:]
    return jnp.linalg.norm(jnp.cross(r, v)) / jnp.dot(r, r)


def kepler_final_anomaly(orbit: KeplerOrbit, duration):
    """True anomaly (rad, continuous) reached `duration` seconds after the epoch."""
    return true_anomaly_from_time(orbit, duration)


def kepler_chief(orbit: KeplerOrbit, s):
    """Keplerian chief at true anomalies s (k,): analytic."""
    def one(f):
        r, v = elements_to_state(orbit, f)
        return jnp.concatenate([r, v]), time_from_true_anomaly(orbit, f)

    state, t = jax.vmap(one)(s)
    return ChiefSamples(s=s, t=t, state=state)


def _integrate(rhs, y0, scale, sigma):
    """(ys at sigma, or at 1 alone for None; ok) over sigma in [0, 1]; ok False when
    `solve_ode` failed (never raises)."""
    ys, status = solve_ode(lambda x, y: rhs(y * scale) / scale, y0 / scale, 0.0, 1.0, sigma,
                           EPHEMERIS)
    return ys * scale, status == Status.SUCCESS


def _scale(orbit, last):
    return jnp.concatenate([jnp.full(3, orbit.a), jnp.full(3, orbit.a * orbit.mean_motion),
                            jnp.ones(1) * last])


def j2_final_anomaly(orbit: KeplerOrbit, duration, j2, r_eq):
    """Regularised anomaly s_f reached after `duration` s on the J2-perturbed orbit that
    osculates `orbit` at its epoch. Returns (s_f, ok); s_f is meaningless where ok is False."""
    r, v = elements_to_state(orbit)

    def rhs(y):
        acc = gravity_acceleration(y[:3], orbit.mu, j2, r_eq)
        return duration * jnp.concatenate([y[3:6], acc, anomaly_rate(y[:6])[None]])

    y0 = jnp.concatenate([r, v, jnp.atleast_1d(orbit.f0 + 0.0 * duration)])
    ys, ok = _integrate(rhs, y0, _scale(orbit, 1.0), None)
    return ys[-1, 6], ok


def j2_chief(orbit: KeplerOrbit, s_f, sigma, j2, r_eq):
    """J2-perturbed chief at s = f0 + (s_f - f0) sigma, sigma (k,) increasing in [0, 1].
    Returns (ChiefSamples, ok); the samples are meaningless where ok is False."""
    r, v = elements_to_state(orbit)
    span = s_f - orbit.f0

    def rhs(y):
        acc = gravity_acceleration(y[:3], orbit.mu, j2, r_eq)
        return span / anomaly_rate(y[:6]) * jnp.concatenate([y[3:6], acc, jnp.ones(1)])

    y0 = jnp.concatenate([r, v, jnp.zeros(1)])
    ys, ok = _integrate(rhs, y0, _scale(orbit, 1.0 / orbit.mean_motion), sigma)
    return ChiefSamples(s=orbit.f0 + span * sigma, t=ys[:, 6], state=ys[:, :6]), ok
