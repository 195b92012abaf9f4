"""Implicit differentiation of root solves: the one place jaxopt is used.

`root(F)` decorates a solver whose output x*(theta) satisfies F(x*, theta) = 0 and
differentiates it by the implicit function theorem, dx*/dtheta = -(dF/dx)^-1 dF/dtheta,
instead of unrolling the solver's iterations. jaxopt is unmaintained; if it breaks, only this
module changes (to `jax.lax.custom_root`).
"""

import jax
import jax.numpy as jnp
from jax.flatten_util import ravel_pytree
from jaxopt import implicit_diff


def _dense_solve(matvec, b, **kwargs):
    """Solve matvec(x) = b exactly by forming the (small) matrix column by column."""
    del kwargs
    flat_b, unravel = ravel_pytree(b)
    basis = jnp.eye(flat_b.size, dtype=flat_b.dtype)
    cols = jax.vmap(lambda v: ravel_pytree(matvec(unravel(v)))[0])(basis)
    return unravel(jnp.linalg.solve(cols.T, flat_b))


def root(optimality_fun):
    """Decorator: `@root(F)` over `solver(init, *theta)` whose result satisfies F(x, *theta) = 0.

    The tangent systems here are small (Kepler's equation, Lambert's time equation), so they
    are solved densely and exactly rather than by jaxopt's default iterative solver.
    """
    return implicit_diff.custom_root(optimality_fun, solve=_dense_solve)
