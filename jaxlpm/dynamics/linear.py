"""Linear relative dynamics in the LVLH frame (x radial, y along-track, z normal).

State x = [x, y, z, vx, vy, vz] (m, m/s); control u = [ux, uy, uz] (m/s^2, LVLH axes).
Each function is for one state; callers vmap.
"""

import jax.numpy as jnp


def hcw_matrix(n):
    """Hill-Clohessy-Wiltshire system matrix (circular chief, mean motion n in rad/s):
    x_dd = 3 n^2 x + 2 n y_d,  y_dd = -2 n x_d,  z_dd = -n^2 z."""
    z = 0.0 * n
    return jnp.array([
        [z, z, z, 1.0 + z, z, z],
        [z, z, z, z, 1.0 + z, z],
        [z, z, z, z, z, 1.0 + z],
        [3 * n**2, z, z, z, 2 * n, z],
        [z, z, z, -2 * n, z, z],
        [z, z, -n**2, z, z, z],
    ])


def hcw_flow(tau):
    """exp(A tau) of the HCW matrix with n = 1 (`hcw_matrix(1.0)`: time tau = n t in rad,
    velocities in length units per rad), in closed form (Clohessy & Wiltshire 1960; Vallado, Fundamentals of Astrodynamics, 4th ed., eq. 6-66), state [x, y, z, vx, vy,
    vz]: no LAPACK call (the matrix exponential's Pade solve is one), exact for any tau."""
    c, s = jnp.cos(tau), jnp.sin(tau)
    z = 0.0 * tau
    return jnp.array([
        [4.0 - 3.0 * c, z, z, s, 2.0 * (1.0 - c), z],
        [6.0 * (s - tau), z + 1.0, z, -2.0 * (1.0 - c), 4.0 * s - 3.0 * tau, z],
        [z, z, c, z, z, s],
        [3.0 * s, z, z, c, 2.0 * s, z],
        [-6.0 * (1.0 - c), z, z, -2.0 * s, 4.0 * c - 3.0, z],
        [z, z, -s, z, z, c],
    ])


def hcw_drift(x, n):
    """A x of `hcw_matrix(n)`, written out: no 6 x 6 product, which XLA:CPU runs slowly point
    by point under vmap."""
    px, py, pz, vx, vy, vz = (x[..., i] for i in range(6))
    return jnp.stack([vx, vy, vz, 3.0 * n**2 * px + 2.0 * n * vy, -2.0 * n * vx, -n**2 * pz],
                     axis=-1)


def hcw_rhs(t, x, u, n):
    """HCW equations dx/dt (m/s, m/s^2)."""
    del t
    return hcw_drift(x, n) + jnp.concatenate([jnp.zeros(3), u])


def hcw_unit_rates(s, x, u, data, params):
    """The HCW equations in tau = n t (n = 1: positions in a length unit L, velocities in
    L n, accelerations u in L n^2), with the `OptimalControlProblem` dynamics signature
    (data and params unused): what the check flights of the HCW families integrate."""
    return hcw_rhs(s, x, u, jnp.ones((), x.dtype))


def elliptic_lvlh_matrix(r, w, w_dot, mu):
    """Linearised relative motion about an elliptic chief, in time (Yamanaka-Ankersen eq. 2):

    x_dd = 2 w y_d + w_dot y + w^2 x + 2 mu x / r^3
    y_dd = -2 w x_d - w_dot x + w^2 y - mu y / r^3
    z_dd = -mu z / r^3
    with the chief's radius r (m), orbital rate w = f_dot (rad/s) and its rate w_dot (rad/s^2).
    """
    g = mu / r**3
    z = 0.0 * g
    return jnp.array([
        [z, z, z, 1.0 + z, z, z],
        [z, z, z, z, 1.0 + z, z],
        [z, z, z, z, z, 1.0 + z],
        [w**2 + 2 * g, w_dot, z, z, 2 * w, z],
        [-w_dot, w**2 - g, z, -2 * w, z, z],
        [z, z, -g, z, z, z],
    ])


def chief_polar_rates(f, e, k2):
    """Chief's radius factor and rates at true anomaly f: returns (rho, w, w_dot) with
    rho = 1 + e cos f, w = f_dot = k^2 rho^2, w_dot = -2 k^4 rho^3 e sin f."""
    rho = 1.0 + e * jnp.cos(f)
    return rho, k2 * rho**2, -2.0 * k2**2 * rho**3 * e * jnp.sin(f)


def elliptic_lvlh_rhs(f, x, u, e, k2, p, mu):
    """Time derivative of the LVLH state (linear, elliptic chief) given the chief's true anomaly
    f at that time (the caller integrates f_dot = k^2 rho^2 beside the state, or solves Kepler)."""
    rho, w, w_dot = chief_polar_rates(f, e, k2)
    A = elliptic_lvlh_matrix(p / rho, w, w_dot, mu)
    return A @ x + jnp.concatenate([jnp.zeros(3), u])


def tschauner_hempel_matrix(f, e):
    """Tschauner-Hempel system matrix in true anomaly for [x~, y~, z~, x~', y~', z~']:
    x~'' = 3 x~ / rho + 2 y~',  y~'' = -2 x~',  z~'' = -z~   (rho = 1 + e cos f; Mei 2010 eq. 1)."""
    rho = 1.0 + e * jnp.cos(f)
    z = 0.0 * rho
    return jnp.array([
        [z, z, z, 1.0 + z, z, z],
        [z, z, z, z, 1.0 + z, z],
        [z, z, z, z, z, 1.0 + z],
        [3.0 / rho, z, z, z, 2.0 + z, z],
        [z, z, z, -2.0 + z, z, z],
        [z, z, -1.0 + z, z, z, z],
    ])


def tschauner_hempel_input_gain(f, e, k2):
    """Gain b(f) = 1 / (k^4 rho^3) (s^2) multiplying u (m/s^2) in x~'' (Mei 2010 eq. 11)."""
    rho = 1.0 + e * jnp.cos(f)
    return 1.0 / (k2**2 * rho**3)


def tschauner_hempel_drift(f, x_th, e):
    """A(f) x~ of `tschauner_hempel_matrix`, written out (Mei 2010 eq. 1): no 6 x 6 product,
    which XLA:CPU runs slowly point by point under vmap."""
    rho = 1.0 + e * jnp.cos(f)
    x, y, z, dx, dy, dz = (x_th[..., i] for i in range(6))
    return jnp.stack([dx, dy, dz, 3.0 * x / rho + 2.0 * dy, -2.0 * dx, -z], axis=-1)


def tschauner_hempel_rhs(f, x_th, u, e, k2):
    """d/df of the Tschauner-Hempel state with physical control u (m/s^2, LVLH axes)."""
    acc = tschauner_hempel_input_gain(f, e, k2) * u
    return tschauner_hempel_drift(f, x_th, e) + jnp.concatenate([jnp.zeros(3), acc])
