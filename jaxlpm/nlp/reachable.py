"""The reachable set of a unit-bounded control on a linear(ised) transcription, by its support
function (Neustadt 1960; Hermes & LaSalle 1969, "Functional analysis and time optimal
control", ch. 13).

A transcription whose final state is x_K = Phi x0 + sum_i P_i v_i (+ o) reaches the states
Phi x0 + o + R with R = {sum_i w_i P_i v_i : |v_i| <= 1} (P_i (n_x, 3), w_i > 0 the weights
of the quadrature or of the controls' effect). Its support function is

    h(p) = max_{r in R} p . r = sum_i w_i |P_i^T p|,

attained by v_i = P_i^T p / |P_i^T p| (full thrust along the primer P_i^T p). A target offset
d is reachable iff p . d <= h(p) for every p, i.e. iff F* = min_{p . d = 1} h(p) >= 1; on the
boundary (F* = 1, the minimum time of a bounded-thrust transfer) the minimiser's primer
directions reach d exactly: sum_i w_i P_i v_i = F* d (the minimiser's optimality condition).
"""

import jax
import jax.numpy as jnp

from ..linalg import small_spd_solve

NEWTON_ITERATIONS = 30     # Newton on p: quadratic where no primer vanishes at a point, and
#                            where one does (a kink of h) the value still settles to round-off


def support(P, w, p):
    """h(p) = sum_i w_i |P_i^T p| (P (m, n_x, 3), w (m,), p (n_x,))."""
    return w @ jnp.linalg.norm(jnp.einsum("kia,i->ka", P, p), axis=1)


def primer_directions(P, p):
    """v_i = P_i^T p / |P_i^T p| (m, 3) (0 where the primer vanishes)."""
    v = jnp.einsum("kia,i->ka", P, p)
    norm = jnp.linalg.norm(v, axis=1, keepdims=True)
    return v / jnp.where(norm > 0.0, norm, 1.0)


def _complement(d):
    """(n_x, n_x - 1) orthonormal columns orthogonal to d: the Householder reflection taking
    e_1 to -sign(d_1) d / |d|, less its first column."""
    v = d / jnp.linalg.norm(d)
    v = v.at[0].add(jnp.where(v[0] >= 0.0, 1.0, -1.0))
    return (jnp.eye(d.shape[0], dtype=d.dtype) - 2.0 * jnp.outer(v, v) / (v @ v))[:, 1:]


def support_minimiser(P, w, d):
    """p* = argmin h(p) subject to p . d = 1: p = p0 + Z y, Z^T d = 0, Newton on y with
    gradient sum_i w_i (P Z)_i v^_i and Hessian sum_i w_i (P Z)_i (I - v^_i v^_i^T)
    (P Z)_i^T / |v_i| (v = P_i^T p, v^ = v / |v|), an Armijo backtracking on h; from the
    Gramian's p0 = W^-1 d / (d . W^-1 d), W = sum_i w_i P_i P_i^T (the energy-optimal
    primer)."""
    p0 = small_spd_solve(jnp.einsum("k,kia,kja->ij", w, P, P), d)[0]
    p0 = p0 / (p0 @ d)
    Z = _complement(d)
    v0 = jnp.einsum("kia,i->ka", P, p0)
    PZ = jnp.einsum("kia,ij->kja", P, Z)

    def f(y):
        return w @ jnp.linalg.norm(v0 + jnp.einsum("kja,j->ka", PZ, y), axis=1)

    def newton(y, _):
        v = v0 + jnp.einsum("kja,j->ka", PZ, y)
        r = jnp.linalg.norm(v, axis=1)
        u = v / r[:, None]
        g = jnp.einsum("k,kja,ka->j", w, PZ, u)
        curv = jnp.eye(3, dtype=v.dtype) - u[:, :, None] * u[:, None, :]
        H = jnp.einsum("k,kia,kab,kjb->ij", w / r, PZ, curv, PZ)
        step = -small_spd_solve(H, g)[0]
        fy, slope = f(y), g @ step

        def halve(t):
            return 0.5 * t[0], t[1] + 1

        alpha, _ = jax.lax.while_loop(
            lambda t: (f(y + t[0] * step) > fy + 1e-4 * t[0] * slope) & (t[1] < 60),
            halve, (jnp.ones((), y.dtype), 0))
        y_new = y + alpha * step
        return jnp.where(f(y_new) <= fy, y_new, y), None

    y, _ = jax.lax.scan(newton, jnp.zeros(d.shape[0] - 1, d.dtype), None,
                        length=NEWTON_ITERATIONS)
    return p0 + Z @ y
