"""Earth gravity for one inertial state: two-body point mass plus the J2 zonal harmonic.

Inertial frame: Earth-centred, z along the Earth's rotation axis (the equatorial frame, e.g.
GCRF/J2000); the zonal J2 field is axially symmetric, so its Earth-fixed z is this z and no
Earth rotation enters. SI units: r in m, accelerations in m/s^2, potentials in m^2/s^2.

Sign convention (astrodynamics): the potential U is positive and the acceleration is +grad U,
        U = (mu / r) [1 - J2 (R_eq / r)^2 P2(sin phi)],   P2(x) = (3 x^2 - 1) / 2,
with geocentric latitude sin phi = z / r (Vallado, Fundamentals of Astrodynamics and
Applications, 4th ed., 2013, ch. 8, gravity field of a central body). Its gradient is the J2
acceleration (Curtis, Orbital Mechanics for Engineering Students, 3rd ed., 2014, ch. 10)
        a_J2 = -(3/2) mu J2 R_eq^2 / r^5 [x (1 - 5 z^2/r^2), y (1 - 5 z^2/r^2), z (3 - 5 z^2/r^2)].
The specific energy v^2/2 - mu/r - U_J2 is conserved under two-body + J2 motion.

`mu`, `j2` and `r_eq` are array leaves: j2 = 0 gives exactly two-body, with no Python branch.
"""

import jax.numpy as jnp


def two_body_acceleration(r, mu):
    """Point-mass gravity -mu r / |r|^3 (m/s^2)."""
    return -mu * r / jnp.linalg.norm(r) ** 3


def j2_potential(r, mu, j2, r_eq):
    """J2 geopotential term U_J2 = -(mu/r) J2 (R_eq/r)^2 P2(z/r) (m^2/s^2); a_J2 = grad U_J2."""
    rn = jnp.linalg.norm(r)
    s = r[2] / rn
    return -(mu / rn) * j2 * (r_eq / rn) ** 2 * 0.5 * (3.0 * s**2 - 1.0)


def _j2_shape(r, s):
    """Q(r) = [x (1 - 5 s^2), y (1 - 5 s^2), z (3 - 5 s^2)] = (1 - 5 s^2) r + 2 z e_z, s = z/r."""
    return (1.0 - 5.0 * s**2) * r + jnp.array([0.0, 0.0, 2.0]) * r[2]


def j2_acceleration(r, mu, j2, r_eq):
    """J2 acceleration -(3/2) mu J2 R_eq^2 Q(r) / r^5 (m/s^2), Q as in `_j2_shape`."""
    rn = jnp.linalg.norm(r)
    return -1.5 * mu * j2 * r_eq**2 * _j2_shape(r, r[2] / rn) / rn**5


def gravity_acceleration(r, mu, j2, r_eq):
    """Two-body + J2 acceleration (m/s^2)."""
    return two_body_acceleration(r, mu) + j2_acceleration(r, mu, j2, r_eq)


def _inv_pow_diff(R, r, dR, n):
    """1/R^n - 1/r^n = -dR (sum_k R^k r^(n-1-k)) / (R r)^n, with dR = R - r formed stably."""
    return -dR * sum(R**k * r ** (n - 1 - k) for k in range(n)) / (R * r) ** n


def gravity_acceleration_difference(r, dr, mu, j2, r_eq):
    """a(r + dr) - a(r) of `gravity_acceleration` without cancellation (m/s^2).

    Encke-style: |r + dr| - |r| = (2 r.dr + dr.dr) / (|r + dr| + |r|), and every power of
    1/r, the latitude term s = z/r and the product P Q in a_J2 = k P Q (P = 1/r^5, k =
    -(3/2) mu J2 R_eq^2) are differenced exactly, Delta(P Q) = P' Delta Q + (Delta P) Q, so
    the result keeps full relative precision for |dr| << |r| (the idea of Encke's method;
    Battin, An Introduction to the Mathematics and Methods of Astrodynamics, 1999, ch. 10).
    """
    rn = jnp.linalg.norm(r)
    rp = r + dr
    Rn = jnp.linalg.norm(rp)
    dR = (2.0 * jnp.dot(r, dr) + jnp.dot(dr, dr)) / (Rn + rn)
    two_body = -mu * (dr / Rn**3 + r * _inv_pow_diff(Rn, rn, dR, 3))
    s, sp = r[2] / rn, rp[2] / Rn
    ds = dr[2] / Rn + r[2] * _inv_pow_diff(Rn, rn, dR, 1)
    dQ = (1.0 - 5.0 * sp**2) * dr - 5.0 * ds * (sp + s) * r + jnp.array([0.0, 0.0, 2.0]) * dr[2]
    dPQ = dQ / Rn**5 + _inv_pow_diff(Rn, rn, dR, 5) * _j2_shape(r, s)
    return two_body - 1.5 * mu * j2 * r_eq**2 * dPQ


def inertial_rhs(state, u, mu, j2, r_eq):
    """d/dt [r, v] = [v, a_grav(r) + u] for one inertial state (m, m/s); u inertial (m/s^2)."""
    r, v = state[:3], state[3:]
    return jnp.concatenate([v, gravity_acceleration(r, mu, j2, r_eq) + u])
