"""The chief's inertial ephemeris at given times: [r, v] (m, m/s) in the inertial frame its
`KeplerOrbit`'s elements are given in, at times t (s since the orbit's epoch).

`kepler_ephemeris`: the Keplerian orbit, analytic (Kepler's equation).
`j2_ephemeris`: the two-body + J2 orbit that osculates the `KeplerOrbit` at its epoch (the
chief of the "j2" model, `jaxlpm.dynamics.chief`), by Encke's method (Battin, An Introduction
to the Mathematics and Methods of Astrodynamics, 1999, ch. 10): the deviation d = r - r_k from
the osculating Keplerian orbit r_k(t) is integrated,

    d'' = a(r_k + d) - a_k(r_k) = [a(r_k + d) - a(r_k)] + a_J2(r_k),

a = two-body + J2 (`gravity_acceleration_difference` forms the bracket without cancellation),
a_k the two-body part. The integrator (`EPHEMERIS`: Dopri8, rtol = atol = 1e-13 on d in units
of DEVIATION_SCALE a) then controls the error of the small deviation (tens of km after half an
orbit), not of the radius: measured 1.7e-7 m over half an orbit of a = 9500 km, e = 0.3
against scipy's DOP853 on the same equation (tests/test_io.py), where integrating r itself
(`propagate`, or `EPHEMERIS` on r) is off by 1e-5 to 4e-4 m.
"""

import jax
import jax.numpy as jnp

from ..orbits import KeplerOrbit, elements_to_state, true_anomaly_from_time
from ..status import Status
from .gravity import gravity_acceleration_difference, j2_acceleration
from .propagation import EPHEMERIS, solve_ode

DEVIATION_SCALE = 1e-4      # the deviation's unit, in semi-major axes (~1 km)


def _kepler_state(orbit: KeplerOrbit, t):
    r, v = elements_to_state(orbit, true_anomaly_from_time(orbit, t))
    return jnp.concatenate([r, v])


def kepler_ephemeris(orbit: KeplerOrbit, ts):
    """[r, v] (len(ts), 6) of the Keplerian orbit at times ts (s since its epoch)."""
    return jax.vmap(lambda t: _kepler_state(orbit, t))(jnp.asarray(ts, jnp.float64))


def j2_ephemeris(orbit: KeplerOrbit, ts, j2, r_eq):
    """[r, v] (len(ts), 6) at times ts (s since the epoch; increasing, ts[-1] > 0) on the
    two-body + J2 orbit (J2 coefficient j2, equatorial radius r_eq in m) that osculates
    `orbit` at its epoch, and ok (False where the integration failed: `solve_ode`)."""
    ts = jnp.asarray(ts, jnp.float64)
    length = DEVIATION_SCALE * orbit.a
    scale = jnp.concatenate([jnp.full(3, length), jnp.full(3, length * orbit.mean_motion)])

    def rhs(t, y):
        d = y * scale
        r_k = _kepler_state(orbit, t)[:3]
        acc = (gravity_acceleration_difference(r_k, d[:3], orbit.mu, j2, r_eq)
               + j2_acceleration(r_k, orbit.mu, j2, r_eq))
        return jnp.concatenate([d[3:], acc]) / scale

    ys, status = solve_ode(rhs, jnp.zeros(6), 0.0, ts[-1], ts, EPHEMERIS)
    return kepler_ephemeris(orbit, ts) + ys * scale, status == Status.SUCCESS
