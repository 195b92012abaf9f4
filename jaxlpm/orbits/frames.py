"""Relative frames: inertial <-> LVLH, LVLH <-> Tschauner-Hempel transformed state.

LVLH (Mei 2010, Yamanaka-Ankersen rotated): origin at the chief, x radial outward (r/|r|),
z along the orbit normal (h/|h|), y = z x x along-track. Relative states are
[x, y, z, vx, vy, vz] in m and m/s, velocities taken in the rotating frame.

Tschauner-Hempel transformed state (true anomaly f as independent variable, rho = 1 + e cos f):
[x~, y~, z~, x~', y~', z~'] with x~ = rho x (m) and ' = d/df (m/rad).
"""

import jax.numpy as jnp


def lvlh_basis(r, v):
    """Rows are the LVLH unit vectors (x radial, y along-track, z normal) in inertial axes."""
    xh = r / jnp.linalg.norm(r)
    h = jnp.cross(r, v)
    zh = h / jnp.linalg.norm(h)
    yh = jnp.cross(zh, xh)
    return jnp.stack([xh, yh, zh])


def inertial_to_lvlh(r_chief, v_chief, r_dep, v_dep):
    """Deputy's LVLH state from the inertial states of chief and deputy (exact, nonlinear).

    rho = C dr, rho_dot = C (dv - w x dr), w = h / |r|^2 the LVLH frame's angular velocity.
    """
    return relative_inertial_to_lvlh(r_chief, v_chief, r_dep - r_chief, v_dep - v_chief)


def relative_inertial_to_lvlh(r_chief, v_chief, dr, dv):
    """LVLH state from the chief's inertial state and the inertial difference (dr, dv)."""
    C = lvlh_basis(r_chief, v_chief)
    w = jnp.cross(r_chief, v_chief) / jnp.dot(r_chief, r_chief)
    return jnp.concatenate([C @ dr, C @ (dv - jnp.cross(w, dr))])


def lvlh_to_relative_inertial(r_chief, v_chief, x_lvlh):
    """Inverse of `relative_inertial_to_lvlh`: inertial (dr, dv) of the deputy w.r.t. the chief."""
    C = lvlh_basis(r_chief, v_chief)
    w = jnp.cross(r_chief, v_chief) / jnp.dot(r_chief, r_chief)
    dr = C.T @ x_lvlh[:3]
    return dr, C.T @ x_lvlh[3:] + jnp.cross(w, dr)


def lvlh_to_th(x_lvlh, f, e, k2):
    """LVLH state (m, m/s) -> Tschauner-Hempel state at chief true anomaly f.

    x~ = rho x, x~' = -e sin f x + x_dot / (k^2 rho)   (Yamanaka & Ankersen 2002, eq. 81-82),
    with k^2 = sqrt(mu/p^3) (1/s) so that f_dot = k^2 rho^2.
    """
    rho = 1.0 + e * jnp.cos(f)
    pos, vel = x_lvlh[:3], x_lvlh[3:]
    return jnp.concatenate([rho * pos, -e * jnp.sin(f) * pos + vel / (k2 * rho)])


def th_to_lvlh(x_th, f, e, k2):
    """Tschauner-Hempel state -> LVLH state: x = x~/rho, x_dot = k^2 (rho x~' + e sin f x~)."""
    rho = 1.0 + e * jnp.cos(f)
    pos, dpos = x_th[:3], x_th[3:]
    return jnp.concatenate([pos / rho, k2 * (rho * dpos + e * jnp.sin(f) * pos)])
