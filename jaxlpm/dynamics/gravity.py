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

`mu`, `j2` and `r_eq` are array leaves: j2 = 0 gives exactly two-body, with no Python branch;
j2 = None leaves the J2 terms out of the program (the two-body models: a smaller program).
"""

import jax
import jax.numpy as jnp
from jax.custom_derivatives import SymbolicZero


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
    """Two-body + J2 acceleration (m/s^2); j2 = None: two-body alone."""
    if j2 is None:
        return two_body_acceleration(r, mu)
    return two_body_acceleration(r, mu) + j2_acceleration(r, mu, j2, r_eq)


def _inv_pow_diff(R, r, dR, n):
    """1/R^n - 1/r^n = -dR (sum_k R^k r^(n-1-k)) / (R r)^n, with dR = R - r formed stably."""
    return -dR * sum(R**k * r ** (n - 1 - k) for k in range(n)) / (R * r) ** n


def _norms(r, dr):
    """(|r|, |r + dr|, |r + dr| - |r| without cancellation: (2 r.dr + dr.dr) / (|r + dr| + |r|))."""
    rn, Rn = jnp.linalg.norm(r), jnp.linalg.norm(r + dr)
    return rn, Rn, (2.0 * jnp.dot(r, dr) + jnp.dot(dr, dr)) / (Rn + rn)


def _two_body_encke(r, dr):
    """a(r + dr) - a(r) of `two_body_acceleration` per unit mu, differenced exactly."""
    rn, Rn, dR = _norms(r, dr)
    return -(dr / Rn**3 + r * _inv_pow_diff(Rn, rn, dR, 3))


def _j2_encke(r, dr):
    """a(r + dr) - a(r) of `j2_acceleration` per unit mu J2 R_eq^2, differenced exactly:
    Delta(P Q) = P' Delta Q + (Delta P) Q with P = 1/r^5, and Delta s of the latitude term
    s = z/r likewise."""
    rn, Rn, dR = _norms(r, dr)
    rp = r + dr
    s, sp = r[2] / rn, rp[2] / Rn
    ds = dr[2] / Rn + r[2] * _inv_pow_diff(Rn, rn, dR, 1)
    dQ = (1.0 - 5.0 * sp**2) * dr - 5.0 * ds * (sp + s) * r + jnp.array([0.0, 0.0, 2.0]) * dr[2]
    return -1.5 * (dQ / Rn**5 + _inv_pow_diff(Rn, rn, dR, 5) * _j2_shape(r, s))


def _difference(unit, encke):
    """g(r + dr) - g(r) for g = `unit`: the value by `encke` (no cancellation), its derivative
    by g's own, J_g(r + dr) (r_dot + dr_dot) - J_g(r) r_dot. The same derivative as the
    formula's, from a far smaller program: Newton-KKT differentiates the dynamics twice, and
    autodiff through the Encke formula's powers made up 43 % of the two-body Newton-KKT
    program (issue 21). The J_g(r) r_dot term cancels where r_dot is not zero (the chief's
    position moves under a parameter: eps |r| / |dr| relative, ~1e-12 at 1 km); r_dot is zero
    in the solvers' Newton systems."""

    @jax.custom_jvp
    def difference(r, dr):
        return encke(r, dr)

    def tangent(primals, tangents):
        r, dr = primals
        r_dot, dr_dot = (None if isinstance(t, SymbolicZero) else t for t in tangents)
        total = r_dot if dr_dot is None else dr_dot if r_dot is None else r_dot + dr_dot
        out = jnp.zeros_like(dr) if total is None else jax.jvp(unit, (r + dr,), (total,))[1]
        if r_dot is not None:
            out = out - jax.jvp(unit, (r,), (r_dot,))[1]
        # the value through `difference` itself: a derivative of this rule (a Hessian) meets
        # the rule again, not autodiff of the Encke formula
        return difference(r, dr), out

    difference.defjvp(tangent, symbolic_zeros=True)
    return difference


# the fields per unit mu (and J2 R_eq^2): the accelerations with unit coefficients
_two_body_difference = _difference(lambda r: two_body_acceleration(r, 1.0), _two_body_encke)
_j2_difference = _difference(lambda r: j2_acceleration(r, 1.0, 1.0, 1.0), _j2_encke)


def gravity_acceleration_difference(r, dr, mu, j2, r_eq):
    """a(r + dr) - a(r) of `gravity_acceleration` without cancellation (m/s^2); j2 = None:
    two-body alone.

    Encke-style: |r + dr| - |r| = (2 r.dr + dr.dr) / (|r + dr| + |r|), and every power of
    1/r, the latitude term s = z/r and the product P Q in a_J2 = k P Q (P = 1/r^5, k =
    -(3/2) mu J2 R_eq^2) are differenced exactly, Delta(P Q) = P' Delta Q + (Delta P) Q, so
    the result keeps full relative precision for |dr| << |r| (the idea of Encke's method;
    Battin, An Introduction to the Mathematics and Methods of Astrodynamics, 1999, ch. 10).
    Derivatives: those of a itself (`_difference`).
    """
    two_body = mu * _two_body_difference(r, dr)
    if j2 is None:
        return two_body
    return two_body + mu * j2 * r_eq**2 * _j2_difference(r, dr)


def inertial_rhs(state, u, mu, j2, r_eq):
    """d/dt [r, v] = [v, a_grav(r) + u] for one inertial state (m, m/s); u inertial (m/s^2)."""
    r, v = state[:3], state[3:]
    return jnp.concatenate([v, gravity_acceleration(r, mu, j2, r_eq) + u])
