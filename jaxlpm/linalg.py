"""Small dense linear algebra shared by the solvers: conditioning reports."""

import jax.numpy as jnp

# A symmetric positive (semi)definite system is called singular below this reciprocal
# condition number: at 1e-13 a float64 solve keeps fewer than 3 significant digits.
RCOND_SINGULAR = 1e-13


def spd_rcond(a):
    """Reciprocal 2-norm condition number of a symmetric PSD matrix after Jacobi scaling
    (D^-1/2 a D^-1/2, D = diag(a)): invariant to the units of the variables; 0 when singular."""
    d = jnp.diagonal(a)
    ok = jnp.all(d > 0)
    s = 1.0 / jnp.sqrt(jnp.where(ok, d, 1.0))
    ev = jnp.linalg.eigvalsh(a * s[:, None] * s[None, :])
    top = jnp.max(jnp.abs(ev))
    rc = jnp.clip(ev[0], 0.0) / jnp.where(top > 0, top, 1.0)
    return jnp.where(ok & (top > 0) & jnp.isfinite(rc), rc, 0.0)
