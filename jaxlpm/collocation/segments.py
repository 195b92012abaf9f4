"""Multi-interval (segmented) meshes: the segmented LGR, LG or LGL mesh of the fuel-optimal and
minimum-time families (`SegmentedMesh`, breaks as fractions of [s0, sf]) and the meshes of the
general transcription on tau in [-1, 1] (`LGRMesh`, `LGMesh`, `LGLMesh`: `Mesh`) (Garg et
al. 2010, "A unified framework for the numerical solution of optimal control problems using
pseudospectral methods", Automatica 46, §4; the hp meshes of Darby, Hager & Rao 2011).

The interval is cut at breaks b_0 < b_1 < ... < b_K; segment k carries the same grid (n
points) mapped onto [b_k, b_{k+1}]: s = b_k + h_k (tau + 1), h_k = (b_{k+1} - b_k) / 2. On
LGR (tau = -1 included, +1 not collocated) the state polynomial of segment k lives on its n
points and b_{k+1}, which is also the first point of segment k + 1, so the state is continuous
across segments by construction; LG and LGL meshes join their segments as `LGMesh` and
`LGLMesh` say. A control (and a bang-bang switch) may jump at a break: breaks placed at the
switching times let each segment hold one smooth arc.

The breaks are an array leaf (moving them does not recompile); K and n are static through the
shapes. `aligned_breaks` (host side, NumPy) builds a mesh with breaks at given switching times.
"""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from .grid import Grid, lg, lgl, lgr


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class SegmentedMesh:
    """K segments of one LGR, LG or LGL grid. breaks (K + 1,) increasing; grid: `lgr(n)`,
    `lg(n)` or `lgl(n)` (the `LGRMesh`, `LGMesh` and `LGLMesh` layouts: LGR segments share
    their break rows, an LG segment's end is its start plus the Gauss quadrature of the
    dynamics, LGL segments each hold their break rows, tied by linkage conditions). The
    condensed transcription (`jaxlpm.problems.fuel_optimal.condensed_mesh`) takes LGR and LG
    segments only (`CONDENSED_SCHEMES`)."""

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
        """s of every segment's state rows, its start and end breaks included: LGR its n
        points (the first is its start) and its end, (K, n + 1); LG its start, its n Gauss
        points and its end, (K, n + 2) (the condensed transcription's layouts)."""
        first = [self.breaks[:-1, None]] if self.grid.scheme == "LG" else []
        return jnp.concatenate([*first, self.points, self.breaks[1:, None]], axis=1)


SEGMENTED_SCHEMES = ("LGR", "LG", "LGL")
CONDENSED_SCHEMES = ("LGR", "LG")
"""The schemes whose segments the condensed transcription eliminates the states of, segment
by segment from its start: an LGL segment collocates both its ends, so its n defects
over-determine its n - 1 state rows after the start and leave conditions on the controls."""


def segmented_mesh(breaks, n: int, scheme: str = "LGR") -> SegmentedMesh:
    """Mesh with the given breaks (K + 1 increasing values) and n points per segment of
    `scheme`: "LGR" (Radau, the default), "LG" (Gauss) or "LGL" (Lobatto)."""
    if scheme not in SEGMENTED_SCHEMES:
        raise ValueError(f"a SegmentedMesh is of scheme {', '.join(SEGMENTED_SCHEMES)}, got "
                         f"{scheme!r}")
    b = np.asarray(breaks, dtype=np.float64)
    if b.ndim != 1 or b.size < 2:
        raise ValueError(f"breaks must be a 1-D array of at least 2 values, got shape {b.shape}")
    if not np.all(np.isfinite(b)) or not np.all(np.diff(b) > 0.0):
        raise ValueError("breaks must be finite and strictly increasing")
    return SegmentedMesh(breaks=jnp.asarray(b), grid=MESHES[scheme][1](n))


def segmented_lgr(breaks, n: int) -> SegmentedMesh:
    """Mesh with the given breaks (K + 1 increasing values) and n LGR points per segment."""
    return segmented_mesh(breaks, n, "LGR")


def segmented_lg(breaks, n: int) -> SegmentedMesh:
    """Mesh with the given breaks (K + 1 increasing values) and n LG points per segment."""
    return segmented_mesh(breaks, n, "LG")


def segmented_lgl(breaks, n: int) -> SegmentedMesh:
    """Mesh with the given breaks (K + 1 increasing values) and n LGL points per segment (the
    fuel-optimal family's augmented Lagrangian: `jaxlpm.solvers.fuel_constrained`)."""
    return segmented_mesh(breaks, n, "LGL")


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


class Mesh:
    """K segments of one grid on tau in [-1, 1], seen as one grid (the hp meshes of Darby,
    Hager & Rao 2011 and Patterson, Hager & Rao 2015; the multi-interval Radau and Gauss
    methods of Garg et al. 2010, and LGL segments joined by linkage conditions, Ross & Fahroo's
    pseudospectral knotting): `LGRMesh`, `LGMesh`, `LGLMesh`.

    It has the attributes of a `Grid` that the transcription reads (`scheme`, `n` = K n_k
    collocation points, `points`, `weights`, `D`, `support`) and the layout of its state rows
    (`jaxlpm.nlp.transcription`): `n_rows`, `state_tau`, `collocated` (the rows at the
    collocation points), `quadrature` (LG: one Gauss-quadrature row per segment) and
    `linkage` (LGL: state continuity at each interior break). D is (K n_k, n_rows), segment
    k's rows the segment grid's matrix times 2 / (b_{k+1} - b_k) on its polynomial's rows;
    weights are the segment's times (b_{k+1} - b_k) / 2. A control may jump at a break.

    breaks   (K + 1,) increasing tau in [-1, 1] (an array leaf: moving them recompiles
             nothing); segment: the segment grid (static). Build with `lgr_mesh`, `lg_mesh`,
             `lgl_mesh` (or `make_mesh`).
    """

    breaks: jax.Array
    segment: Grid

    # per scheme: state rows per segment before the next segment's first row (`_stride`),
    # the segment's first collocated row within them (`_offset`), rows after the last
    # segment's (`_tail`)
    _stride_extra = 0
    _offset = 0
    _tail = 1

    @property
    def n_segments(self) -> int:
        return self.breaks.shape[-1] - 1

    @property
    def n(self) -> int:
        return self.n_segments * self.segment.n

    @property
    def xp(self):
        """NumPy for breaks known on the host (a constant mesh: its points and weights need
        no small program compiled per operation), jax.numpy for traced ones."""
        return jnp if isinstance(self.breaks, jax.core.Tracer) else np

    @property
    def _b(self):
        """The breaks as `xp` computes with them."""
        return self.xp.asarray(self.breaks)

    @property
    def _half(self):
        return 0.5 * self.xp.diff(self._b, axis=-1)                    # (..., K)

    @property
    def _stride(self) -> int:
        return self.segment.n + self._stride_extra

    @property
    def _support_length(self) -> int:
        """Rows of one segment's state polynomial."""
        return self.segment.support.shape[0]

    @property
    def n_rows(self) -> int:
        return self.n_segments * self._stride + self._tail

    # points, weights and the tau of the rows also take a batch of meshes (breaks
    # (..., K + 1)), as a batched solution holds them
    def _mapped(self, tau):
        """Segment-local tau (n_k,) on every segment: (..., K, n_k)."""
        xp = self.xp
        return self._b[..., :-1, None] + self._half[..., None] * (xp.asarray(tau) + 1.0)

    @property
    def points(self):
        """tau of the K n_k collocation points, segment by segment."""
        tau = self._mapped(self.segment.points)
        return tau.reshape(*tau.shape[:-2], -1)

    @property
    def weights(self):
        w = self._half[..., None] * self.xp.asarray(self.segment.weights)
        return w.reshape(*w.shape[:-2], -1)

    @property
    def state_tau(self):
        """tau of the `n_rows` state rows: each segment's first `_stride` support rows, then
        the final break where the layout has a tail."""
        tau = self._mapped(self.segment.support)[..., :self._stride]
        tau = tau.reshape(*tau.shape[:-2], -1)
        return (self.xp.concatenate([tau, self._b[..., -1:]], axis=-1) if self._tail
                else tau)

    @property
    def support(self):
        """tau of the rows the state polynomials live on: every state row."""
        return self.state_tau

    @property
    def collocated(self):
        """The state rows at the collocation points: a slice where they are contiguous, else
        an index array (K n_k,)."""
        if self._stride == self.segment.n and self._offset == 0:
            return slice(0, self.n)
        seg, i = np.meshgrid(np.arange(self.n_segments), np.arange(self.segment.n),
                             indexing="ij")
        return (seg * self._stride + self._offset + i).reshape(-1)

    @property
    def D(self):
        """(K n_k, n_rows) block differentiation matrix in tau."""
        k, m, p = self.n_segments, self.segment.n, self._support_length
        seg, i, j = np.meshgrid(np.arange(k), np.arange(m), np.arange(p), indexing="ij")
        values = jnp.asarray(self.segment.D)[None] / self._half[:, None, None]
        return jnp.zeros((k * m, self.n_rows), values.dtype).at[
            seg * m + i, seg * self._stride + j].set(values)

    def differentiate(self, values):
        """D @ values for values (n_rows, ...), segment by segment: each segment grid's D on
        its polynomial's rows, over h_k (K n_k p work, not (K n_k) n_rows)."""
        k, p = self.n_segments, self._support_length
        rows = values[np.arange(k)[:, None] * self._stride + np.arange(p)[None]]
        out = jnp.einsum("ij,kj...->ki...", jnp.asarray(self.segment.D), rows)
        out = out / self._half.reshape((k,) + (1,) * (out.ndim - 1))
        return out.reshape((k * self.segment.n,) + values.shape[1:])

    quadrature = None      # (E (q, n_rows), W (q, n)) for LG: E X - h W F = 0
    linkage = None         # L (p, n_rows) for LGL: L X = 0

    def locate(self, tau):
        """(segment index k, local tau in [-1, 1]) of a scalar tau (a break belongs to the
        later segment; the ends clip into the first and last)."""
        k = jnp.clip(jnp.searchsorted(self.breaks, tau, side="right") - 1, 0,
                     self.n_segments - 1)
        return k, (tau - jnp.asarray(self.breaks)[k]) / jnp.asarray(self._half)[k] - 1.0

    def interpolate_state(self, values, tau):
        """State interpolant at scalar tau: values (n_rows, ...) on `support`, segment k's
        polynomial on its rows."""
        k, local = self.locate(tau)
        rows = jax.lax.dynamic_slice_in_dim(values, k * self._stride, self._support_length)
        return self.segment.interpolate_state(rows, local)

    def interpolate_control(self, values, tau):
        """Control interpolant at scalar tau: values (K n_k, ...), segment k's n_k points."""
        k, local = self.locate(tau)
        g = self.segment
        rows = jax.lax.dynamic_slice_in_dim(values, k * g.n, g.n)
        return g.interpolate_control(rows, local)


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class LGRMesh(Mesh):
    """K segments of `lgr(n_k)` (Garg et al. 2010's multi-interval Radau method): segment k's
    n_k Radau points (its start collocated) and its end, which is the next segment's first
    point, give the state rows [points, +1]: the state is continuous by construction, and D
    is block bidiagonal (`Mesh`)."""

    breaks: jax.Array
    segment: Grid

    scheme = "LGR"


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class LGMesh(Mesh):
    """K segments of `lg(n_k)` (Garg et al. 2010's multi-interval Gauss method): the state rows
    are each break and the segment's Gauss points after it, then the final break, [b_0, G_1,
    b_1, G_2, ..., G_K, b_K]; segment k's polynomial lives on [b_k, G_k] and its end break is
    tied to it by the Gauss quadrature of the dynamics, X(b_{k+1}) = X(b_k) + h_k sum_i w_i F_i
    (`quadrature`, one row per segment), so the state is continuous by construction."""

    breaks: jax.Array
    segment: Grid

    scheme = "LG"
    _stride_extra = 1
    _offset = 1

    @property
    def quadrature(self):
        """(E (K, n_rows), W (K, K n_k)): row k of E X - h W F is X(b_{k+1}) - X(b_k) - h_k
        sum_i w_i F_i (W holds each segment's `weights` on its own points)."""
        k, m = self.n_segments, self.segment.n
        seg = np.arange(k)
        E = np.zeros((k, self.n_rows))
        E[seg, seg * self._stride] = -1.0
        E[seg, (seg + 1) * self._stride] = 1.0
        W = jnp.zeros((k, k * m), self.breaks.dtype).at[
            np.repeat(seg, m), np.arange(k * m)].set(self.weights)
        return jnp.asarray(E), W


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class LGLMesh(Mesh):
    """K segments of `lgl(n_k)`, every point collocated (Fahroo & Ross 2001 on each segment):
    a break is a state row of both segments it joins (the rows are the K n_k points, the break
    twice), and the two are tied by the linkage condition X(b_k^-) = X(b_k^+) (`linkage`); the
    control may jump there (Ross & Fahroo's pseudospectral knotting)."""

    breaks: jax.Array
    segment: Grid

    scheme = "LGL"
    _tail = 0

    @property
    def joins(self):
        """(rows of X(b_k^-), rows of X(b_k^+)) at the interior breaks, NumPy (K - 1,) each."""
        seg, m = np.arange(self.n_segments - 1), self.segment.n
        return seg * m + m - 1, (seg + 1) * m

    @property
    def linkage(self):
        """L (K - 1, n_rows): row k of L X is X(b_{k+1}^-) - X(b_{k+1}^+) (`joins`)."""
        L = np.zeros((self.n_segments - 1, self.n_rows))
        left, right = self.joins
        L[np.arange(left.size), left] = 1.0
        L[np.arange(right.size), right] = -1.0
        return jnp.asarray(L)


MESHES = {"LGR": (LGRMesh, lgr), "LG": (LGMesh, lg), "LGL": (LGLMesh, lgl)}


def make_mesh(scheme: str, k: int, n: int, breaks=None) -> Mesh:
    """A `Mesh` of k segments of the scheme's grid with n points each ("LGR": `LGRMesh`,
    "LG": `LGMesh`, "LGL": `LGLMesh`) on tau in [-1, 1]: breaks (k + 1 increasing values from
    -1 to 1) or, by default, k equal segments."""
    if scheme not in MESHES:
        raise ValueError(f"scheme must be one of {sorted(MESHES)}, got {scheme!r}")
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
        raise ValueError(f"the number of segments must be a positive integer, got {k!r}")
    b = uniform_breaks(-1.0, 1.0, k) if breaks is None else np.asarray(breaks, np.float64)
    if b.shape != (k + 1,) or not np.all(np.isfinite(b)) or not np.all(np.diff(b) > 0.0) \
            or b[0] != -1.0 or b[-1] != 1.0:
        raise ValueError(f"breaks must be {k + 1} strictly increasing values from -1 to 1, "
                         f"got {b}")
    cls, grid = MESHES[scheme]
    return cls(breaks=jnp.asarray(b), segment=grid(n))


def lg_mesh(k: int, n: int, breaks=None) -> LGMesh:
    """`LGMesh` of k segments of lg(n) on tau in [-1, 1] (`make_mesh`)."""
    return make_mesh("LG", k, n, breaks)


def lgl_mesh(k: int, n: int, breaks=None) -> LGLMesh:
    """`LGLMesh` of k segments of lgl(n) on tau in [-1, 1] (`make_mesh`)."""
    return make_mesh("LGL", k, n, breaks)


def lgr_mesh(k: int, n: int, breaks=None) -> LGRMesh:
    """`LGRMesh` of k segments of lgr(n) on tau in [-1, 1] (`make_mesh`)."""
    return make_mesh("LGR", k, n, breaks)


def as_segmented(mesh):
    """A `SegmentedMesh` as it is; an `LGRMesh`, `LGMesh` or `LGLMesh` (breaks in tau, e.g. a
    solution's grid) as the `SegmentedMesh` of the same segments with breaks as fractions
    (tau + 1) / 2."""
    if isinstance(mesh, Mesh):
        return SegmentedMesh(breaks=0.5 * (mesh.breaks + 1.0), grid=mesh.segment)
    return mesh


def tau_mesh(mesh: SegmentedMesh) -> Mesh:
    """The `LGRMesh`, `LGMesh` or `LGLMesh` of a `SegmentedMesh` (breaks as fractions), in
    tau in [-1, 1]: the inverse of `as_segmented`."""
    return MESHES[mesh.grid.scheme][0](breaks=2.0 * mesh.breaks - 1.0, segment=mesh.grid)
