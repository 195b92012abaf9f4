"""Relative frames: inertial <-> LVLH, LVLH <-> Tschauner-Hempel transformed state.

LVLH (Mei 2010, Yamanaka-Ankersen rotated): origin at the chief, x radial outward (r/|r|),
z along the orbit normal (h/|h|), y = z x x along-track. Relative states are
[x, y, z, vx, vy, vz] in m and m/s, velocities taken in the rotating frame: with C the matrix
whose rows are the LVLH axes and w the frame's inertial angular velocity,
rho = C dr, rho_dot = d/dt (C dr) = C (dv - w x dr). For a perturbed chief pass its total
acceleration (`a_chief`): it tilts the orbit plane and adds an x component to w.

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


def lvlh_angular_velocity(r, v, a=None):
    """Inertial angular velocity of the chief's LVLH frame (rad/s, inertial axes).

    w = (|r| (a . z^) / |h|) x^ + (|h| / r^2) z^ = (a . h / |h|^2) r + h / r^2, from
    dx^/dt = w x x^ and dz^/dt = w x z^: dx^/dt = (v - (x^.v) x^)/|r| = (|h|/r^2) y^ fixes
    w_y = 0, w_z = |h|/r^2; h_dot = r x a gives dz^/dt = -(|r| a_z/|h|) y^ = -w_x y^.
    a is the chief's total acceleration (m/s^2); a=None is Keplerian (a || r): w = h / r^2.
    """
    h = jnp.cross(r, v)
    w = h / jnp.dot(r, r)
    if a is None:
        return w
    return w + jnp.dot(a, h) / jnp.dot(h, h) * r


def inertial_to_lvlh(r_chief, v_chief, r_dep, v_dep, a_chief=None):
    """Deputy's LVLH state from the inertial states of chief and deputy (exact, nonlinear).

    rho = C dr, rho_dot = C (dv - w x dr), w = `lvlh_angular_velocity(r_chief, v_chief, a_chief)`.
    """
    return relative_inertial_to_lvlh(r_chief, v_chief, r_dep - r_chief, v_dep - v_chief, a_chief)


def relative_inertial_to_lvlh(r_chief, v_chief, dr, dv, a_chief=None):
    """LVLH state from the chief's inertial state and the inertial difference (dr, dv);
    a_chief: the chief's acceleration (m/s^2) when it is not Keplerian."""
    C = lvlh_basis(r_chief, v_chief)
    w = lvlh_angular_velocity(r_chief, v_chief, a_chief)
    return jnp.concatenate([C @ dr, C @ (dv - jnp.cross(w, dr))])


def lvlh_to_relative_inertial(r_chief, v_chief, x_lvlh, a_chief=None):
    """Inverse of `relative_inertial_to_lvlh`: inertial (dr, dv) of the deputy w.r.t. the chief,
    dr = C^T rho, dv = C^T rho_dot + w x dr."""
    C = lvlh_basis(r_chief, v_chief)
    w = lvlh_angular_velocity(r_chief, v_chief, a_chief)
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
