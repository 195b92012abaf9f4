"""Implicit differentiation of root solves: the one place jaxopt is used.

`root(F)` decorates a solver whose output x*(theta) satisfies F(x*, theta) = 0 and
differentiates it by the implicit function theorem, dx*/dtheta = -(dF/dx)^-1 dF/dtheta,
instead of unrolling the solver's iterations. jaxopt is unmaintained; if it breaks, only this
module changes (to `jax.lax.custom_root`).
"""

import functools

import jax
import jax.numpy as jnp
from jax.flatten_util import ravel_pytree

from .linalg import lu_solve


def _dense_solve(matvec, b, **kwargs):
    """Solve matvec(x) = b exactly by forming the (small) matrix column by column."""
    del kwargs
    flat_b, unravel = ravel_pytree(b)
    basis = jnp.eye(flat_b.size, dtype=flat_b.dtype)
    cols = jax.vmap(lambda v: ravel_pytree(matvec(unravel(v)))[0])(basis)
    # a vmapped gradient batches this solve: `lu_solve` makes no batched LAPACK call, which
    # can deadlock XLA's CPU pool (`jaxlpm.linalg.sequential_when_batched`)
    return unravel(lu_solve(cols.T, flat_b))


def _dense_solve_or_zero(matvec, b, **kwargs):
    """`_dense_solve` whose non-finite solution (a singular tangent system) is replaced by 0."""
    x = _dense_solve(matvec, b, **kwargs)
    flat, unravel = ravel_pytree(x)
    return unravel(jnp.where(jnp.all(jnp.isfinite(flat)), flat, 0.0))


def root(optimality_fun, has_aux: bool = False, zero_nonfinite: bool = False):
    """Decorator: `@root(F)` over `solver(init, *theta)` whose result satisfies F(x, *theta) = 0.

    With has_aux the solver returns (x, aux) and aux (status, counters) is not differentiated.
    The tangent systems are solved densely and exactly (Kepler's equation, Lambert's time
    equation, a collocation KKT system of ~10^3 unknowns, the Riccati equation's n^2 x n^2
    Lyapunov operator), not by jaxopt's default iterative solver, whose loose defaults would
    spoil gradients. With zero_nonfinite a singular tangent system (a solve that failed and
    says so in its status) gives zero derivatives instead of NaN, so a batch whose failed
    members are masked with jnp.where keeps finite gradients.
    """
    solve = _dense_solve_or_zero if zero_nonfinite else _dense_solve

    def decorate(solver):
        # jaxopt (and the scipy.optimize it imports, ~0.3 s) is imported at the first call,
        # not when a module decorates its solver: `import jaxlpm` stays quick (issue 21)
        @functools.wraps(solver)
        def rooted(*args, **kwargs):
            if rooted.implicit is None:
                from jaxopt import implicit_diff

                rooted.implicit = implicit_diff.custom_root(
                    optimality_fun, has_aux=has_aux, solve=solve)(solver)
            return rooted.implicit(*args, **kwargs)

        rooted.implicit = None
        return rooted

    return decorate
