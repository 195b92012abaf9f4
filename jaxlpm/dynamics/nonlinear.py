"""Nonlinear relative motion of a deputy about a chief, both under two-body + J2 gravity.

No linearisation: the deputy's relative acceleration is the exact difference of the two
inertial gravity accelerations (`gravity_acceleration_difference`, free of cancellation) plus
its control. Two state forms, for one state each (callers vmap):

- inertial: s = [r_c, v_c, dr, dv] (m, m/s), the chief's state and the deputy's offset;
- LVLH: the chief's inertial [r_c, v_c] beside the deputy's LVLH state [rho, rho_dot]
  (x radial outward, y along-track, z orbit normal; m, m/s, velocity in the rotating frame).

Controls u_lvlh are the deputy's accelerations in LVLH axes (m/s^2); the chief is uncontrolled.
j2 = 0 gives two-body motion exactly.
"""

import jax
import jax.numpy as jnp

from ..orbits.frames import lvlh_angular_velocity, lvlh_basis
from .gravity import gravity_acceleration, gravity_acceleration_difference


def relative_inertial_rhs(s, u_lvlh, mu, j2, r_eq):
    """d/dt [r_c, v_c, dr, dv] = [v_c, a(r_c), dv, a(r_c + dr) - a(r_c) + C^T u_lvlh],
    a = two-body + J2 gravity, C = `lvlh_basis(r_c, v_c)` (rows: LVLH axes in inertial axes)."""
    rc, vc, dr, dv = s[:3], s[3:6], s[6:9], s[9:12]
    ac = gravity_acceleration(rc, mu, j2, r_eq)
    ad = gravity_acceleration_difference(rc, dr, mu, j2, r_eq) + lvlh_basis(rc, vc).T @ u_lvlh
    return jnp.concatenate([vc, ac, dv, ad])


def lvlh_frame_motion(chief, mu, j2, r_eq):
    """The chief's LVLH frame: (C, w, w_dot), C's rows the LVLH axes in inertial axes, w and
    w_dot its angular velocity (rad/s) and acceleration (rad/s^2) in LVLH components.

    w = `lvlh_angular_velocity(r_c, v_c, a(r_c))`; w_dot = C d/dt w_inertial, the time
    derivative taken along [v_c, a(r_c)] by forward-mode differentiation (it carries the jerk
    of the J2-perturbed chief). chief = [r_c, v_c] (inertial, m, m/s).
    """
    rc, vc = chief[:3], chief[3:]

    def w_inertial(r, v):
        return lvlh_angular_velocity(r, v, gravity_acceleration(r, mu, j2, r_eq))

    w, w_dot = jax.jvp(w_inertial, (rc, vc), (vc, gravity_acceleration(rc, mu, j2, r_eq)))
    C = lvlh_basis(rc, vc)
    return C, C @ w, C @ w_dot


def relative_lvlh_acceleration(r_chief, frame, x_lvlh, u_lvlh, mu, j2, r_eq):
    """rho_ddot (m/s^2, LVLH) of the deputy's LVLH state x_lvlh = [rho, rho_dot] (m, m/s):

        rho_ddot = C (a(r_c + C^T rho) - a(r_c)) + u - 2 w x rho_dot - w_dot x rho - w x (w x rho)

    (the transport theorem in the rotating frame; e.g. Schaub & Junkins, Analytical Mechanics of
    Space Systems, ch. 14), frame = (C, w, w_dot) from `lvlh_frame_motion`, the gravity
    difference free of cancellation (`gravity_acceleration_difference`)."""
    C, w, w_dot = frame
    rho, rho_dot = x_lvlh[:3], x_lvlh[3:]
    da = C @ gravity_acceleration_difference(r_chief, C.T @ rho, mu, j2, r_eq)
    return (da + u_lvlh - 2.0 * jnp.cross(w, rho_dot) - jnp.cross(w_dot, rho)
            - jnp.cross(w, jnp.cross(w, rho)))


def relative_lvlh_rhs(chief, x_lvlh, u_lvlh, mu, j2, r_eq):
    """Exact d/dt of the deputy's LVLH state x_lvlh = [rho, rho_dot] (m, m/s -> m/s, m/s^2),
    chief = [r_c, v_c] (inertial, m, m/s): `relative_lvlh_acceleration` in the frame of
    `lvlh_frame_motion`, two-body + J2 gravity on both spacecraft (j2 = 0: two-body)."""
    frame = lvlh_frame_motion(chief, mu, j2, r_eq)
    acc = relative_lvlh_acceleration(chief[:3], frame, x_lvlh, u_lvlh, mu, j2, r_eq)
    return jnp.concatenate([x_lvlh[3:], acc])
