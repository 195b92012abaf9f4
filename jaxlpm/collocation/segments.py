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


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class LGRMesh:
    """K segments of one LGR grid on tau in [-1, 1], seen as one grid (the hp meshes of
    Darby, Hager & Rao 2011 and Patterson, Hager & Rao 2015, in the form of Garg et al. 2010's
    multi-interval Radau method).

    It has the attributes of an LGR `Grid` that the transcription reads (`scheme` "LGR",
    `n` = K n_k collocation points, `points`, `weights`, `support`, `D`), so every solver of
    `jaxlpm.nlp` runs on it unchanged: segment k's n_k Radau points (its start collocated)
    and its end, which is the next segment's first point (the state is continuous by
    construction), give the state rows [points, +1]; D is block bidiagonal, segment k's rows
    the LGR matrix times 2 / (b_{k+1} - b_k) on its n_k + 1 rows; weights are the LGR weights
    times (b_{k+1} - b_k) / 2. A control may jump at a break.

    breaks   (K + 1,) increasing tau in [-1, 1] (an array leaf: moving them recompiles
             nothing); segment: `lgr(n_k)` (static). Build with `lgr_mesh`.
    """

    breaks: jax.Array
    segment: Grid

    scheme = "LGR"

    @property
    def n_segments(self) -> int:
        return self.breaks.shape[-1] - 1

    @property
    def n(self) -> int:
        return self.n_segments * self.segment.n

    @property
    def _half(self):
        return 0.5 * jnp.diff(self.breaks, axis=-1)                      # (..., K)

    # points, weights and support also take a batch of meshes (breaks (..., K + 1)), as a
    # batched solution holds them
    @property
    def points(self):
        """tau of the K n_k collocation points, segment by segment."""
        g = self.segment
        tau = (self.breaks[..., :-1, None]
               + self._half[..., None] * (jnp.asarray(g.points) + 1.0))
        return tau.reshape(*tau.shape[:-2], -1)

    @property
    def weights(self):
        w = self._half[..., None] * jnp.asarray(self.segment.weights)
        return w.reshape(*w.shape[:-2], -1)

    @property
    def support(self):
        """tau of the K n_k + 1 state rows."""
        return jnp.concatenate([self.points, self.breaks[..., -1:]], axis=-1)

    @property
    def D(self):
        """(K n_k, K n_k + 1) block bidiagonal differentiation matrix in tau."""
        k, m = self.n_segments, self.segment.n
        seg, i, j = np.meshgrid(np.arange(k), np.arange(m), np.arange(m + 1), indexing="ij")
        values = jnp.asarray(self.segment.D)[None] / self._half[:, None, None]
        return jnp.zeros((k * m, k * m + 1), values.dtype).at[
            seg * m + i, seg * m + j].set(values)

    def locate(self, tau):
        """(segment index k, local tau in [-1, 1]) of a scalar tau (a break belongs to the
        later segment; the ends clip into the first and last)."""
        k = jnp.clip(jnp.searchsorted(self.breaks, tau, side="right") - 1, 0,
                     self.n_segments - 1)
        return k, (tau - self.breaks[k]) / self._half[k] - 1.0

    def interpolate_state(self, values, tau):
        """State interpolant at scalar tau: values (K n_k + 1, ...) on `support`, segment k's
        polynomial on its n_k + 1 rows."""
        k, local = self.locate(tau)
        g = self.segment
        rows = jax.lax.dynamic_slice_in_dim(values, k * g.n, g.n + 1)
        return g.interpolate_state(rows, local)

    def interpolate_control(self, values, tau):
        """Control interpolant at scalar tau: values (K n_k, ...), segment k's n_k points."""
        k, local = self.locate(tau)
        g = self.segment
        rows = jax.lax.dynamic_slice_in_dim(values, k * g.n, g.n)
        return g.interpolate_control(rows, local)


def lgr_mesh(k: int, n: int, breaks=None) -> LGRMesh:
    """`LGRMesh` of k segments of lgr(n) on tau in [-1, 1]: breaks (k + 1 increasing values
    from -1 to 1) or, by default, k equal segments."""
    b = uniform_breaks(-1.0, 1.0, k) if breaks is None else np.asarray(breaks, np.float64)
    if b.shape != (k + 1,) or not np.all(np.isfinite(b)) or not np.all(np.diff(b) > 0.0) \
            or b[0] != -1.0 or b[-1] != 1.0:
        raise ValueError(f"breaks must be {k + 1} strictly increasing values from -1 to 1, "
                         f"got {b}")
    return LGRMesh(breaks=jnp.asarray(b), segment=lgr(n))


def as_segmented(mesh):
    """A `SegmentedMesh` as it is; an `LGRMesh` (breaks in tau, e.g. a solution's grid) as the
    `SegmentedMesh` of the same segments with breaks as fractions (tau + 1) / 2."""
    if isinstance(mesh, LGRMesh):
        return SegmentedMesh(breaks=0.5 * (mesh.breaks + 1.0), grid=mesh.segment)
    return mesh
