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

The entries come from `ya_inplane_entries` / `ya_outofplane_entries` / `ya_entries`: nested
lists whose structural zeros and ones are Python numbers, so that a batched law can apply the
matrices as explicit multiply-adds over node arrays that skip them (jaxlpm.solvers.lq), instead
of stacking (4, 4, n) arrays and contracting them with small einsums, which XLA:CPU runs slowly.
"""

import jax.numpy as jnp
import numpy as np

_PERM = np.array([1, 0, 3, 2])            # ours[a] = SIGN[a] * ya[PERM[a]]
_SIGN = np.array([-1.0, 1.0, -1.0, 1.0])
IP = np.array([0, 1, 3, 4])               # in-plane / out-of-plane slots of the 6-state
OP = np.array([2, 5])


def _ours(m_ya):
    """P M P^T for a YA-axes in-plane nested list:
    ours[a][b] = SIGN[a] SIGN[b] ya[PERM[a]][PERM[b]]."""
    return [[m_ya[_PERM[a]][_PERM[b]] if _SIGN[a] * _SIGN[b] > 0 else -m_ya[_PERM[a]][_PERM[b]]
             for b in range(4)] for a in range(4)]


def stack_entries(m, shape):
    """Array of shape (rows, cols, *shape) from a nested list of entries (numbers broadcast)."""
    dtype = jnp.result_type(*[x for row in m for x in row])
    return jnp.stack([jnp.stack([jnp.broadcast_to(jnp.asarray(x, dtype), shape) for x in row])
                      for row in m])


def ya_inplane_entries(sf, cf, e):
    """(F0, F1, F^-1) of YA eq. (84) (Phi_theta = F0(f) + J F1(f)) and eq. (85) (F^-1, J = 0)
    from sin f, cos f, in-plane, our axes, as 4x4 nested lists of arrays shaped like sf (Python
    numbers for the structural zeros and ones). cos 2f = 2 cos^2 f - 1, sin 2f = 2 sin f cos f:
    no transcendental beyond sin f and cos f."""
    rho = 1.0 + e * cf
    s, c = rho * sf, rho * cf
    sp = cf + e * (2.0 * cf * cf - 1.0)                  # d(rho sin f)/df
    cp = -(sf + e * (2.0 * sf * cf))                     # d(rho cos f)/df
    F0 = [
        [1.0, -c * (1 + 1 / rho), s * (1 + 1 / rho), 0.0],
        [0.0, s, c, 2.0],
        [0.0, 2 * s, 2 * c - e, 3.0],
        [0.0, sp, cp, -3 * e * s / rho**2],
    ]
    F1 = [
        [0.0, 0.0, 0.0, 3 * rho**2],
        [0.0, 0.0, 0.0, -3 * e * s],
        [0.0, 0.0, 0.0, -6 * e * s],
        [0.0, 0.0, 0.0, -3 * e * sp],
    ]
    det = 1 - e**2
    Finv = [
        [1.0, 3 * e * s * (1 / rho + 1 / rho**2) / det, -e * s * (1 + 1 / rho) / det,
         (-e * c + 2) / det],
        [0.0, -3 * s * (1 / rho + e**2 / rho**2) / det, s * (1 + 1 / rho) / det,
         (c - 2 * e) / det],
        [0.0, -3 * (c / rho + e) / det, (c * (1 + 1 / rho) + e) / det, -s / det],
        [0.0, (3 * rho + e**2 - 1) / det, -rho**2 / det, e * s / det],
    ]
    return _ours(F0), _ours(F1), _ours(Finv)


def ya_outofplane_entries(sf, cf):
    """(F, F^-1) of z~'' = -z~ for [z~, z~'] (YA eq. 83) from sin f, cos f, as 2x2 nested
    lists: F is a rotation, so F^-1 = F^T."""
    F = [[cf, sf], [-sf, cf]]
    return F, [[cf, -sf], [sf, cf]]


def ya_entries(sf, cf, e):
    """(F0, F1, F^-1) of the full TH state [x~, y~, z~, x~', y~', z~'] as 6x6 nested lists:
    the in-plane blocks of `ya_inplane_entries` at the IP slots, the out-of-plane ones of
    `ya_outofplane_entries` at the OP slots (F1 = 0 there), structural zeros elsewhere."""
    (F0, F1, Finv), (R, Rinv) = ya_inplane_entries(sf, cf, e), ya_outofplane_entries(sf, cf)
    zero = [[0.0, 0.0], [0.0, 0.0]]
    return tuple(_block_diagonal(ip, op) for ip, op in ((F0, R), (F1, zero), (Finv, Rinv)))


def _block_diagonal(ip, op):
    """6x6 nested list with the 4x4 `ip` at the IP slots, the 2x2 `op` at OP, zeros elsewhere."""
    m = [[0.0] * 6 for _ in range(6)]
    for block, slots in ((ip, IP), (op, OP)):
        for a, i in enumerate(slots):
            for b, j in enumerate(slots):
                m[i][j] = block[a][b]
    return m


def ya_inplane_fundamental(f, e):
    """(F0, F1): YA's Phi_theta (eq. 84) = F0(f) + J F1(f), in-plane 4x4, our axes."""
    F0, F1, _ = ya_inplane_entries(jnp.sin(f), jnp.cos(f), e)
    shape = jnp.broadcast_shapes(jnp.shape(f), jnp.shape(e))
    return stack_entries(F0, shape), stack_entries(F1, shape)


def ya_inplane_inverse(f0, e):
    """F^-1 at f0 (YA eq. 85; J = 0 there), in-plane 4x4, our axes."""
    _, _, Finv = ya_inplane_entries(jnp.sin(f0), jnp.cos(f0), e)
    return stack_entries(Finv, jnp.broadcast_shapes(jnp.shape(f0), jnp.shape(e)))


def ya_outofplane_fundamental(f):
    """Out-of-plane fundamental matrix of z~'' = -z~ for [z~, z~'] (YA eq. 83); its inverse is
    its transpose."""
    F, _ = ya_outofplane_entries(jnp.sin(f), jnp.cos(f))
    return stack_entries(F, jnp.shape(f))


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
