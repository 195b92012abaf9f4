"""Multi-interval (segmented) Legendre-Gauss-Radau meshes (Garg et al. 2010, "A unified
framework for the numerical solution of optimal control problems using pseudospectral
methods", Automatica 46, §4; the hp meshes of Darby, Hager & Rao 2011).

The interval [s0, sf] is cut at breaks s0 = b_0 < b_1 < ... < b_K = sf; segment k carries the
same LGR grid (n points, tau = -1 included, +1 not collocated) mapped onto [b_k, b_{k+1}]:
s = b_k + h_k (tau + 1), h_k = (b_{k+1} - b_k) / 2. The state polynomial of segment k lives on
its n points and b_{k+1}; b_{k+1} is also the first point of segment k + 1, so the state is
continuous across segments by construction. A control (and a bang-bang switch) may jump at a
break: breaks placed at the switching times let each segment hold one smooth arc.

The breaks are an array leaf (moving them does not recompile); K and n are static through the
shapes. `aligned_breaks` (host side, NumPy) builds a mesh with breaks at given switching times.
"""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from .grid import Grid, lgr


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class SegmentedMesh:
    """K segments of one LGR grid. breaks (K + 1,) increasing; grid: `lgr(n)`."""

    breaks: jax.Array
    grid: Grid

    @property
    def n_segments(self) -> int:
        return self.breaks.shape[-1] - 1

    @property
    def n_points(self) -> int:
        """Collocation points in all (K n)."""
        return self.n_segments * self.grid.n

    @property
    def half_lengths(self):
        """h_k = (b_{k+1} - b_k) / 2, (K,)."""
        return 0.5 * jnp.diff(self.breaks)

    @property
    def points(self):
        """s of the collocation points, (K, n)."""
        h = self.half_lengths[:, None]
        return self.breaks[:-1, None] + h * (self.grid.points[None] + 1.0)

    @property
    def weights(self):
        """Quadrature weights h_k w_i in s (K, n): int f ds ~ sum w f at `points`."""
        return self.half_lengths[:, None] * self.grid.weights[None]

    @property
    def state_points(self):
        """s of every segment's state rows (its n points and its end break), (K, n + 1)."""
        return jnp.concatenate([self.points, self.breaks[1:, None]], axis=1)


def segmented_lgr(breaks, n: int) -> SegmentedMesh:
    """Mesh with the given breaks (K + 1 increasing values) and n LGR points per segment."""
    b = np.asarray(breaks, dtype=np.float64)
    if b.ndim != 1 or b.size < 2:
        raise ValueError(f"breaks must be a 1-D array of at least 2 values, got shape {b.shape}")
    if not np.all(np.isfinite(b)) or not np.all(np.diff(b) > 0.0):
        raise ValueError("breaks must be finite and strictly increasing")
    return SegmentedMesh(breaks=jnp.asarray(b), grid=lgr(n))


def uniform_breaks(s0: float, sf: float, k: int) -> np.ndarray:
    """K equal segments of [s0, sf]."""
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
        raise ValueError(f"the number of segments must be a positive integer, got {k!r}")
    return np.linspace(float(s0), float(sf), int(k) + 1)


def aligned_breaks(s0: float, sf: float, k: int, switches, min_gap: float = 1e-6) -> np.ndarray:
    """K segments with a break at every switching time in (s0, sf).

    The arcs between consecutive switches (and the ends) get at least one segment each; the
    remaining K - (arcs) segments go to the arcs in proportion to their lengths (largest
    remainder), each arc cut evenly. Switches closer than min_gap (sf - s0) to an end or to
    each other are merged. Raises ValueError if K is smaller than the number of arcs.
    """
    s0, sf = float(s0), float(sf)
    span = sf - s0
    sw = np.sort(np.asarray(switches, dtype=np.float64).reshape(-1))
    sw = sw[np.isfinite(sw) & (sw > s0 + min_gap * span) & (sf - sw > min_gap * span)]
    if sw.size:
        sw = sw[np.concatenate([[True], np.diff(sw) > min_gap * span])]
    edges = np.concatenate([[s0], sw, [sf]])
    lengths = np.diff(edges)
    arcs = lengths.size
    if k < arcs:
        raise ValueError(f"{arcs - 1} switching times need at least {arcs} segments, got k = {k}")
    share = (k - arcs) * lengths / span
    counts = 1 + np.floor(share).astype(int)
    extra = k - counts.sum()
    counts[np.argsort(-(share - np.floor(share)))[:extra]] += 1
    pieces = [np.linspace(a, b, c + 1)[:-1] for a, b, c in zip(edges[:-1], edges[1:], counts)]
    return np.concatenate(pieces + [[sf]])
