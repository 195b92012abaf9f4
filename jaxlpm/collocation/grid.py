"""Collocation grids (LGL, LG, LGR) on tau in [-1, 1] as JAX pytrees.

Operators are built on the host in float64 and cached per (scheme, n); see `Grid`.
"""

import dataclasses
import functools

import jax
import numpy as np

from jaxlpm._validation import require_x64

from .barycentric import (
    barycentric_interpolate,
    barycentric_weights,
    differentiation_matrix,
    integration_matrix,
)
from .legendre import lg_nodes_weights, lgl_nodes_weights, lgr_nodes_weights

_MIN_POINTS = {"LGL": 3, "LG": 1, "LGR": 2}


@dataclasses.dataclass(frozen=True, eq=False)
class Grid:
    """Collocation grid with n collocation points and its operators (float64).

    A grid is fixed by (scheme, n): its operators are read-only host (numpy) constants, so as a
    pytree it has no leaves and its treedef holds (scheme, n) only (jit specialises on it and
    hashes and compares it by (scheme, n), whichever copy of the operators it holds; vmap never
    copies it into each member of a batched solution).

    points (n,), weights (n,): collocation points tau_i and quadrature weights.
    support (n_s,): nodes of the state polynomial: LGL the points (Mei 2010);
      LG [-1, points] (Benson et al. 2006; x_f = x_0 + sum_k w_k f_k by quadrature);
      LGR [points, +1] (Garg et al. 2010; non-collocated final point).
    D (n, n_s): (D x)_i = d/dtau of the state interpolant at points_i.
    support_bary (n_s,), point_bary (n,): barycentric weights for state / control interpolation.
    integration (n, n): A_ij = int_{-1}^{points_i} l_j, l_j the Lagrange basis on the points.
    """

    scheme: str
    n: int
    points: jax.Array
    weights: jax.Array
    support: jax.Array
    D: jax.Array
    support_bary: jax.Array
    point_bary: jax.Array
    integration: jax.Array

    def __hash__(self):
        return hash((self.scheme, self.n))

    def __eq__(self, other):
        return isinstance(other, Grid) and (self.scheme, self.n) == (other.scheme, other.n)

    def interpolate_state(self, values, tau):
        """State interpolant at scalar tau; values (n_s, ...) on `support`."""
        return barycentric_interpolate(self.support, self.support_bary, values, tau)

    def interpolate_control(self, values, tau):
        """Control interpolant at scalar tau; values (n, ...) on `points`."""
        return barycentric_interpolate(self.points, self.point_bary, values, tau)


@functools.lru_cache(maxsize=None)
def _host_operators(scheme: str, n: int) -> dict:
    """Read-only float64 numpy operators of `Grid` for (scheme, n)."""
    if scheme == "LGL":
        points, weights = lgl_nodes_weights(n)
        support, rows = points, slice(None)
    elif scheme == "LG":
        points, weights = lg_nodes_weights(n)
        support, rows = np.concatenate(([-1.0], points)), slice(1, None)
    else:
        points, weights = lgr_nodes_weights(n)
        support, rows = np.concatenate((points, [1.0])), slice(None, -1)
    support_bary = barycentric_weights(support)
    ops = {
        "points": points,
        "weights": weights,
        "support": support,
        "D": differentiation_matrix(support, support_bary)[rows],
        "support_bary": support_bary,
        "point_bary": barycentric_weights(points),
        "integration": integration_matrix(points),
    }
    for arr in ops.values():
        arr.setflags(write=False)
    return ops


jax.tree_util.register_pytree_node(
    Grid, lambda grid: ((), (grid.scheme, grid.n)),
    lambda key, _: Grid(*key, **_host_operators(*key)))


def make_grid(scheme: str, n: int) -> Grid:
    """Grid for scheme "LGL", "LG" or "LGR" with n collocation points."""
    if scheme not in _MIN_POINTS:
        raise ValueError(f"scheme must be one of {sorted(_MIN_POINTS)}, got {scheme!r}")
    minimum = _MIN_POINTS[scheme]
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < minimum:
        raise ValueError(
            f"{scheme} grid needs an integer number of collocation points >= {minimum}, got {n!r}"
        )
    require_x64()
    return Grid(scheme=scheme, n=int(n), **_host_operators(scheme, int(n)))


def lgl(n_points: int) -> Grid:
    """Legendre-Gauss-Lobatto grid with n_points = N + 1 points (lgl(65) is N = 64 in Mei 2010)."""
    return make_grid("LGL", n_points)


def lg(k: int) -> Grid:
    """Legendre-Gauss grid with k collocation points (Gauss pseudospectral method)."""
    return make_grid("LG", k)


def lgr(k: int) -> Grid:
    """Legendre-Gauss-Radau grid with k collocation points, -1 included (Radau PM)."""
    return make_grid("LGR", k)
