"""Yamanaka-Ankersen state transition matrix for the Tschauner-Hempel equations.

Yamanaka & Ankersen, "New state transition matrix for relative motion on an arbitrary
elliptical orbit", JGCD 25(1), 2002, eq. (82)-(86), written in our LVLH axes (x radial out,
y along-track, z normal): with YA's axes (x_Y along-track, z_Y radial inward, y_Y = -h) the
in-plane state maps as [x~, y~, x~', y~'] = [-z_Y, x_Y, -z_Y', x_Y'].

Phi(f, f0) = F(f; J) F^-1(f0), where YA's fundamental matrix F is affine in the secular term
J = k^2 (t - t0): F = F0(f) + J F1(f). J is the time since the START of the transition (s
times 1/s), never wrapped at one period: callers pass dt = t - t0 computed continuously.
Full 6x6 matrices act on the TH state [x~, y~, z~, x~', y~', z~'].
"""

import jax.numpy as jnp
import numpy as np

# Our in-plane state = P @ YA in-plane state; embedded into the 6-state at these indices.
_P = np.array([[0.0, -1.0, 0.0, 0.0],
               [1.0, 0.0, 0.0, 0.0],
               [0.0, 0.0, 0.0, -1.0],
               [0.0, 0.0, 1.0, 0.0]])
_IP = np.array([0, 1, 3, 4])
_OP = np.array([2, 5])
_EMBED_IP = np.zeros((6, 4))
_EMBED_IP[_IP, np.arange(4)] = 1.0
_EMBED_OP = np.zeros((6, 2))
_EMBED_OP[_OP, np.arange(2)] = 1.0
_E = _EMBED_IP @ _P          # 6x4: YA in-plane -> our 6-state


def _embed(ip_ya, op):
    """6x6 matrix from a YA-axes in-plane 4x4 block and an out-of-plane 2x2 block."""
    return _E @ ip_ya @ _E.T + _EMBED_OP @ op @ _EMBED_OP.T


def ya_fundamental(f, e):
    """(F0, F1): YA's Phi_theta (eq. 84) = F0(f) + J F1(f), as 6x6 matrices in our axes.

    The out-of-plane part (z~'' = -z~) is the rotation [[cos f, sin f], [-sin f, cos f]].
    """
    rho = 1.0 + e * jnp.cos(f)
    sf, cf = jnp.sin(f), jnp.cos(f)
    s, c = rho * sf, rho * cf
    sp = cf + e * jnp.cos(2 * f)
    cp = -(sf + e * jnp.sin(2 * f))
    o, z = jnp.ones_like(rho), jnp.zeros_like(rho)
    F0 = jnp.array([
        [o, -c * (1 + 1 / rho), s * (1 + 1 / rho), z],
        [z, s, c, 2 * o],
        [z, 2 * s, 2 * c - e, 3 * o],
        [z, sp, cp, -3 * e * s / rho**2],
    ])
    F1 = jnp.array([
        [z, z, z, 3 * rho**2],
        [z, z, z, -3 * e * s],
        [z, z, z, -6 * e * s],
        [z, z, z, -3 * e * sp],
    ])
    rot = jnp.array([[cf, sf], [-sf, cf]])
    return _embed(F0, rot), _embed(F1, jnp.zeros((2, 2), dtype=rho.dtype))


def ya_fundamental_inverse(f0, e):
    """F^-1 at f0 (YA eq. 85; J = 0 there) as a 6x6 matrix in our axes."""
    rho = 1.0 + e * jnp.cos(f0)
    sf, cf = jnp.sin(f0), jnp.cos(f0)
    s, c = rho * sf, rho * cf
    z = jnp.zeros_like(rho)
    m = jnp.array([
        [1 - e**2 + z, 3 * e * s * (1 / rho + 1 / rho**2), -e * s * (1 + 1 / rho), -e * c + 2],
        [z, -3 * s * (1 / rho + e**2 / rho**2), s * (1 + 1 / rho), c - 2 * e],
        [z, -3 * (c / rho + e), c * (1 + 1 / rho) + e, -s],
        [z, 3 * rho + e**2 - 1, -rho**2, e * s],
    ]) / (1 - e**2)
    rot_t = jnp.array([[cf, -sf], [sf, cf]])
    return _embed(m, rot_t)


def yamanaka_ankersen_stm(f, f0, dt, e, k2):
    """6x6 STM of the Tschauner-Hempel state from f0 to f (rad, continuous).

    dt = t - t0 (s, continuous, any sign); k2 = sqrt(mu/p^3) (1/s).
    """
    F0, F1 = ya_fundamental(f, e)
    return (F0 + k2 * dt * F1) @ ya_fundamental_inverse(f0, e)


def yamanaka_ankersen_inplane(f, f0, dt, e, k2):
    """In-plane 4x4 STM for [x~, y~, x~', y~']."""
    return yamanaka_ankersen_stm(f, f0, dt, e, k2)[np.ix_(_IP, _IP)]


def yamanaka_ankersen_outofplane(f, f0):
    """Out-of-plane 2x2 STM for [z~, z~'] (YA eq. 83; Mei 2010 prints it for [z~', z~]):
    a rotation by f - f0."""
    d = f - f0
    return jnp.array([[jnp.cos(d), jnp.sin(d)], [-jnp.sin(d), jnp.cos(d)]])
