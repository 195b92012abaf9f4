"""Yamanaka-Ankersen state transition matrix for the Tschauner-Hempel equations.

Yamanaka & Ankersen, "New state transition matrix for relative motion on an arbitrary
elliptical orbit", JGCD 25(1), 2002, eq. (82)-(86), written in our LVLH axes (x radial out,
y along-track, z normal). YA's axes are x_Y along-track, z_Y radial inward, y_Y = -h, so the
in-plane state maps as [x~, y~, x~', y~'] = [-z_Y, x_Y, -z_Y', x_Y'] (a signed permutation,
applied here by indexing, not by matrix products).

Phi(f, f0) = F(f; J) F^-1(f0), where YA's fundamental matrix F is affine in the secular term
J = k^2 (t - t0): F = F0(f) + J F1(f). J is the time since the START of the transition (s
times 1/s), never wrapped at one period: callers pass dt = t - t0 computed continuously.
In-plane state [x~, y~, x~', y~'] (4x4), out-of-plane [z~, z~'] (2x2), full TH state
[x~, y~, z~, x~', y~', z~'] (6x6). The fundamental-matrix functions are elementwise in f: for
an array of anomalies they return shape (4, 4, *f.shape), matrix axes first (node values
contiguous, which is what batched laws want).
"""

import jax.numpy as jnp
import numpy as np

_PERM = np.array([1, 0, 3, 2])            # ours[a] = SIGN[a] * ya[PERM[a]]
_SIGN = np.array([-1.0, 1.0, -1.0, 1.0])
_SIGNS = _SIGN[:, None] * _SIGN[None, :]
IP = np.array([0, 1, 3, 4])               # in-plane / out-of-plane slots of the 6-state
OP = np.array([2, 5])


def _ours(m_ya):
    """P M P^T for YA-axes in-plane matrices of shape (4, 4, ...)."""
    signs = _SIGNS.reshape(_SIGNS.shape + (1,) * (m_ya.ndim - 2))
    return m_ya[_PERM][:, _PERM] * signs


def ya_inplane_fundamental(f, e):
    """(F0, F1): YA's Phi_theta (eq. 84) = F0(f) + J F1(f), in-plane 4x4, our axes."""
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
    return _ours(F0), _ours(F1)


def ya_inplane_inverse(f0, e):
    """F^-1 at f0 (YA eq. 85; J = 0 there), in-plane 4x4, our axes."""
    rho = 1.0 + e * jnp.cos(f0)
    s, c = rho * jnp.sin(f0), rho * jnp.cos(f0)
    z = jnp.zeros_like(rho)
    m = jnp.array([
        [1 - e**2 + z, 3 * e * s * (1 / rho + 1 / rho**2), -e * s * (1 + 1 / rho), -e * c + 2],
        [z, -3 * s * (1 / rho + e**2 / rho**2), s * (1 + 1 / rho), c - 2 * e],
        [z, -3 * (c / rho + e), c * (1 + 1 / rho) + e, -s],
        [z, 3 * rho + e**2 - 1, -rho**2, e * s],
    ]) / (1 - e**2)
    return _ours(m)


def ya_outofplane_fundamental(f):
    """Out-of-plane fundamental matrix of z~'' = -z~ for [z~, z~'] (YA eq. 83); its inverse is
    its transpose."""
    c, s = jnp.cos(f), jnp.sin(f)
    return jnp.array([[c, s], [-s, c]])


def yamanaka_ankersen_inplane(f, f0, dt, e, k2):
    """In-plane 4x4 STM for [x~, y~, x~', y~'] from f0 to f; dt = t - t0 (s), k2 (1/s)."""
    F0, F1 = ya_inplane_fundamental(f, e)
    return (F0 + k2 * dt * F1) @ ya_inplane_inverse(f0, e)


def yamanaka_ankersen_outofplane(f, f0):
    """Out-of-plane 2x2 STM for [z~, z~'] (Mei 2010 prints it for [z~', z~]): a rotation by
    f - f0."""
    return ya_outofplane_fundamental(f) @ ya_outofplane_fundamental(f0).T


def yamanaka_ankersen_stm(f, f0, dt, e, k2):
    """6x6 STM of the Tschauner-Hempel state from f0 to f (rad, continuous).

    dt = t - t0 (s, continuous, any sign); k2 = sqrt(mu/p^3) (1/s).
    """
    ip = yamanaka_ankersen_inplane(f, f0, dt, e, k2)
    phi = jnp.zeros((6, 6), dtype=ip.dtype).at[np.ix_(IP, IP)].set(ip)
    return phi.at[np.ix_(OP, OP)].set(yamanaka_ankersen_outofplane(f, f0))
