"""Nonlinear relative motion: two-body chief and deputy, differenced exactly.

State s = [r_c, v_c, dr, dv] (inertial, m and m/s): the chief's state and the deputy's
inertial offset from it. The offset's acceleration is the exact difference of the two
two-body accelerations (no linearisation), plus the deputy's control rotated from LVLH.
"""

import jax.numpy as jnp

from ..orbits import lvlh_basis


def two_body_acceleration(r, mu):
    """-mu r / |r|^3 (m/s^2)."""
    return -mu * r / jnp.linalg.norm(r) ** 3


def relative_two_body_rhs(s, u_lvlh, mu):
    """d/dt of [r_c, v_c, dr, dv]; u_lvlh: deputy's control acceleration in LVLH (m/s^2)."""
    rc, vc, dr, dv = s[:3], s[3:6], s[6:9], s[9:12]
    ac = two_body_acceleration(rc, mu)
    ad = two_body_acceleration(rc + dr, mu) - ac + lvlh_basis(rc, vc).T @ u_lvlh
    return jnp.concatenate([vc, ac, dv, ad])
