"""Barycentric Lagrange interpolation (Berrut & Trefethen, SIAM Review 46, 2004).

Host builders (numpy, float64): barycentric weights, differentiation, integration and
interpolation matrices. `barycentric_interpolate` is the traceable JAX evaluator.
"""

import jax.numpy as jnp
import numpy as np

from .legendre import legendre_table


def barycentric_weights(x) -> np.ndarray:
    """b_j = 1 / prod_{k != j} (x_j - x_k), normalised so that max |b_j| = 1.

    Each difference is scaled by 4 / (max x - min x) (the inverse logarithmic capacity of the
    interval) so the product stays O(n) instead of under/overflowing like 2^{-n}.
    A single point gets b = [1].
    """
    x = np.asarray(x, dtype=np.float64)
    span = x.max() - x.min()
    diff = (x[:, None] - x[None, :]) * (4.0 / span if span > 0 else 1.0)
    np.fill_diagonal(diff, 1.0)
    b = 1.0 / np.prod(diff, axis=1)
    return b / np.max(np.abs(b))


def differentiation_matrix(x, b) -> np.ndarray:
    """Square D with (D v)_i = p'(x_i), p the interpolant of v on x (Berrut & Trefethen eq. 9.4).

    D_ij = (b_j / b_i) / (x_i - x_j) for i != j; D_ii = -sum_{j != i} D_ij (exact on constants).
    The derivative at a subset of x is a row selection of D.
    """
    x = np.asarray(x, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    diff = x[:, None] - x[None, :]
    np.fill_diagonal(diff, 1.0)
    d = (b[None, :] / b[:, None]) / diff
    np.fill_diagonal(d, 0.0)
    np.fill_diagonal(d, -d.sum(axis=1))
    return d


def integration_matrix(x) -> np.ndarray:
    """A_ij = int_{-1}^{x_i} l_j(tau) dtau, l_j the Lagrange basis on nodes x (n points).

    With the Legendre Vandermonde V_im = P_m(x_i) (m < n), l_j = sum_m (V^{-1})_mj P_m, and
    int_{-1}^{s} P_m = (P_{m+1}(s) - P_{m-1}(s)) / (2m+1) (m >= 1), s + 1 (m = 0); A = W V^{-1}.
    """
    x = np.asarray(x, dtype=np.float64)
    n = x.size
    p, _ = legendre_table(n, x)
    v = p[:n].T
    w = np.empty((n, n))
    w[:, 0] = x + 1.0
    m = np.arange(1, n)
    w[:, 1:] = ((p[2:] - p[:-2]) / (2 * m + 1)[:, None]).T
    return np.linalg.solve(v.T, w.T).T


def interpolation_matrix(x, b, t) -> np.ndarray:
    """(len(t), n) matrix M with (M v)_i = p(t_i): M_ij = (b_j/(t_i-x_j)) / sum_k b_k/(t_i-x_k).

    Rows of t equal to a node x_j (with b_j != 0) are the unit row e_j.
    """
    x = np.asarray(x, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    t = np.atleast_1d(np.asarray(t, dtype=np.float64))
    diff = t[:, None] - x[None, :]
    hit = (diff == 0.0) & (b[None, :] != 0.0)
    on_node = hit.any(axis=1, keepdims=True)
    c = b[None, :] / np.where(diff == 0.0, 1.0, diff)
    m = c / np.where(on_node, 1.0, c.sum(axis=1, keepdims=True))
    return np.where(on_node, hit.astype(np.float64), m)


def barycentric_interpolate(x, b, values, t):
    """Interpolant p(t) of `values` (n, ...) on support x with barycentric weights b; t scalar.

    Second (true) barycentric formula p = sum_j c_j v_j / sum_j c_j, c_j = b_j / (t - x_j),
    rewritten about the nearest node k (multiply through by t - x_k):
        p(t) = v_k + (t - x_k) sum_{j!=k} c_j (v_j - v_k) / (b_k + (t - x_k) sum_{j!=k} c_j).
    This is smooth at t = x_k, returns v_k exactly there, and its t-derivative there is
    sum_j D_kj v_j. Support points with b_j = 0 (padding) contribute nothing.
    """
    x = jnp.asarray(x)
    b = jnp.asarray(b)
    values = jnp.asarray(values)
    t = jnp.asarray(t)
    diff = t - x
    live = b != 0
    k = jnp.argmin(jnp.where(live, jnp.abs(diff), jnp.inf))
    skip = (jnp.arange(x.shape[0]) == k) | ~live
    c = jnp.where(skip, 0.0, b / jnp.where(skip, 1.0, diff))
    vk = values[k]
    h = diff[k]
    num = jnp.tensordot(c, values - vk, axes=1)
    return vk + h * num / (b[k] + h * jnp.sum(c))
