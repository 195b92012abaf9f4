"""The length scale the relative-transfer families nondimensionalise by (one rule for all).

L = max(|r0|, |rf|, 1 m) from the boundary positions (m): the solver's states are O(1) in it,
velocities in L n (n the chief's mean motion), accelerations in L n^2. Its norms are written
to have a finite derivative at zero (a transfer from rest at the chief, r0 = 0, is common and
`jax.grad` of its cost with respect to x0 must not be NaN).
"""

import jax.numpy as jnp


def safe_norm(v, axis=None):
    """|v| (over `axis`, default all) with derivative 0 (not NaN) at v = 0."""
    sq = jnp.sum(v * v, axis=axis)
    return jnp.where(sq > 0.0, jnp.sqrt(jnp.where(sq > 0.0, sq, 1.0)), 0.0)


def length_scale(problem):
    """L = max(|r0|, |rf|, 1 m) of a problem with LVLH boundary states x0, xf."""
    return jnp.maximum(jnp.maximum(safe_norm(problem.x0[:3]), safe_norm(problem.xf[:3])), 1.0)


def state_scale(problem):
    """SI LVLH state = state_scale * the solver's state: [L] * 3, [L n] * 3."""
    L, n = length_scale(problem), problem.orbit.mean_motion
    return jnp.concatenate([jnp.full(3, L), jnp.full(3, L * n)])
