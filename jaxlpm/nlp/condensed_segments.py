"""The condensed Newton-KKT step on LGR meshes of many segments, formed and factored segment by
segment.

`CondensedSecondOrder` writes the interior positions as p_0 + Z y with Z a dense orthonormal
null-space basis, so its reduced Hessian T^T H T is dense: on 16 x 16 LGR points forming it
costs about 2 GFLOP, some 60 ms, per Newton iteration. On an `LGRMesh`
(Garg et al. 2010's multi-interval Radau method) the same step has a local basis. The only
condition left on the interior positions (`CondensedSecondOrder`) is the initial velocity,
dV(0) = (D dR)_0 / (h q_0): one row of the first segment's D per axis. Solve it for one
pivot row p of the first segment (the largest |D_0p|, so every other coefficient is at most
1 in size) and keep every other interior position as an unknown. A displacement of a row of
segment t changes the velocities of segment t (and of t - 1 at its first row) and through
them the controls of segments t - 1 and t (t - 2 at its first row). So group the unknowns in
blocks b_t = the rows t n + 1 .. t n + n (n points per segment, the last the next segment's
first row): block t touches the points of segments t - 1, t and t + 1 only, and the reduced
Hessian is block pentadiagonal, i.e. block tridiagonal in pairs of blocks.

Blocks three apart touch no common point, so one evaluation of the step's linear map on the
sum of every third block's unit displacement gives all their columns of T at once (the
column compression of Curtis, Powell & Reid 1974): 9 n evaluations instead of one per unknown.
Each segment's points then add their (3 blocks x 3 n)^2 local products to the band, and the
band is solved by block Cholesky (`block_tridiagonal_solve`): at 32 x 16 points 16 blocks of
96 in place of a dense 1533 x 1533 factorisation.

The step and multipliers are `CondensedSecondOrder`'s: the null-space step is unique for a
positive definite reduced Hessian whatever the basis, and p_0 still solves A p_0 = -r.
"""

import jax
import jax.numpy as jnp
import numpy as np

from ..collocation import lgr
from ..collocation.segments import LGRMesh
from ..linalg import block_tridiagonal_solve
from .condensed import CondensedSecondOrder
from .transcription import collocated_rows, differentiate, point_hessians

MIN_SEGMENTS = 4
"""Fewer segments keep the dense reduced Hessian: the band would be the whole matrix."""


def segments_apply(ocp, grid) -> bool:
    """Whether `SegmentedCondensed` takes the problem: an `LGRMesh` of at least `MIN_SEGMENTS`
    segments and a fixed final s."""
    return (isinstance(grid, LGRMesh) and grid.n_segments >= MIN_SEGMENTS
            and not bool(ocp.free_final))


class SegmentedCondensed(CondensedSecondOrder):
    """`CondensedSecondOrder`'s step on an `LGRMesh` (`segments_apply`), its reduced Hessian
    block-banded (module docstring). The unknowns w are laid out (K, n, 3): block t, local row
    j (state row t n + 1 + j), axis; the pivot row and the final row (fixed by the boundary
    rows) are padding, held at zero."""

    def __init__(self, ocp, grid, z_ref=None):
        if not segments_apply(ocp, grid):
            raise ValueError(f"SegmentedCondensed takes an LGRMesh of at least {MIN_SEGMENTS} "
                             f"segments and a fixed final s")
        self.K, self.nk = grid.n_segments, grid.segment.n
        first_row = np.abs(np.asarray(lgr(self.nk).D)[0, 1:])   # rows 1..n of segment 0
        self.pivot = 1 + int(np.argmax(first_row))
        live = np.ones((self.K, self.nk, 3))
        live[0, self.pivot - 1] = 0.0
        live[-1, -1] = 0.0
        self.live = live
        # seeds: unit displacements of local row j, axis a in every third block (colour o)
        seeds = np.zeros((3, self.nk, 3, self.K, self.nk, 3))
        for o in range(3):
            for j in range(self.nk):
                for a in range(3):
                    seeds[o, j, a, o::3, j, a] = 1.0
        self.seeds = (seeds * live).reshape(9 * self.nk, -1)
        # segment s's window: blocks s - 1, s, s + 1, whose colours are (s - 1 + slot) mod 3
        self.colour = (np.arange(self.K)[:, None] - 1 + np.arange(3)[None]) % 3
        super().__init__(ocp, grid, z_ref)

    # ------------------------------------------------------------------ the local basis
    def _rows(self, w, r, dtype):
        """dR (rows, 3): the ends from the boundary rows, the interior from w (pads zero)."""
        w = (w.reshape(self.K, self.nk, 3) * self.live).reshape(-1, 3)
        return self._ends(r, dtype).at[1:self.n_rows - 1].set(w[:-1])

    def _null_space(self, coef, dtype):
        """d dV(0) / d dR_p per axis (3,): the initial-velocity condition's pivot coefficients
        (the position defects act on each axis alike)."""
        zero_r = self._zero_r(dtype)

        def unmet(v):
            dR = jnp.zeros((self.n_rows, 3), dtype).at[self.pivot].set(v)
            return self._complete(dR, zero_r, coef)[2][0]

        return jnp.diagonal(jax.jacfwd(unmet)(jnp.zeros(3, dtype)))

    def _pivoted(self, dR, r, coef, pivot):
        """dR with its pivot row set so that the initial velocity is met."""
        return dR.at[self.pivot].set(-self._complete(dR, r, coef)[2][0] / pivot)

    def _z_independent(self, coef, dtype):
        """(pivot coefficients, compressed directions): dX (rows, 6, 9 n) and D dV / (h b)
        (points, 3, 9 n) of the seeds."""
        pivot = self._null_space(coef, dtype)
        zero_r = self._zero_r(dtype)
        h, _, b = coef[:3]

        def direction(seed):
            dX = self._states(self._pivoted(self._rows(seed, zero_r, dtype), zero_r, coef,
                                            pivot), zero_r, coef)
            return dX, differentiate(self.grid, dX[:, 3:]) / (h * b[:, None])

        return pivot, jax.vmap(direction, out_axes=-1)(jnp.asarray(self.seeds, dtype))

    def _step(self, basis, w, r):
        """T w + p_0(r) (fixed final s)."""
        coef, pivot, _ = basis
        dR = self._pivoted(self._rows(w, r, r.dtype), r, coef, pivot)
        dX, dU, _ = self._complete(dR, r, coef)
        return jnp.concatenate([dX.ravel(), dU.ravel()])

    def _particular(self, basis, r):
        return self._step(basis, jnp.zeros(self.live.size, r.dtype), r)

    # ------------------------------------------------------------------ the band
    def _windows(self, basis):
        """T at each segment's points over its window's unknowns: (K, n, 9, 3 * 3 n), rows
        (r, v, u) of the point, columns (slot, local row, axis)."""
        coef, _, (dX, dU_D) = basis
        b, Gd = coef[2], coef[3]
        dX = dX[collocated_rows(self.grid)]
        dU = dU_D - jnp.einsum("iab,ibk->iak", Gd, dX) / b[:, None, None]
        Tp = jnp.concatenate([dX, dU], axis=1).reshape(self.K, self.nk, 9, 3, 3 * self.nk)
        Tw = jnp.take_along_axis(Tp, jnp.asarray(self.colour)[:, None, None, :, None], axis=3)
        return Tw.reshape(self.K, self.nk, 9, 9 * self.nk)

    def _band(self, local):
        """Segment products local (K, 3 slots x 3 n, same) summed into the block-tridiagonal
        form of pairs of blocks: (diagonal (m, 6 n, 6 n), below (m - 1, 6 n, 6 n)), the
        padding's diagonal 1 (its rows and columns are zero)."""
        K, k = self.K, 3 * self.nk
        L = local.reshape(K, 3, k, 3, k)

        def shift(x, before, after):
            return jnp.pad(x, [(before, after)] + [(0, 0)] * (x.ndim - 1))

        # extended blocks e = t + 1 (t = -1 .. K): segment s adds its slot w to block s + w
        diag = shift(L[:, 0, :, 0], 0, 2) + shift(L[:, 1, :, 1], 1, 1) + shift(L[:, 2, :, 2], 2, 0)
        below1 = shift(L[:, 1, :, 0], 0, 1) + shift(L[:, 2, :, 1], 1, 0)
        diag, below1, below2 = diag[1:K + 1], below1[1:K], L[1:K - 1, 2, :, 0]
        diag = diag + jax.vmap(jnp.diag)(jnp.asarray(1.0 - self.live).reshape(K, k))
        if K % 2:                                          # one identity block: an even count
            diag = jnp.concatenate([diag, jnp.eye(k, dtype=diag.dtype)[None]])
            below1 = shift(below1, 0, 1)
            below2 = shift(below2, 0, 1)
        zero = jnp.zeros_like(diag[0])
        pair = jnp.block([[diag[0::2], jnp.swapaxes(below1[0::2], 1, 2)],
                          [below1[0::2], diag[1::2]]])
        below = jnp.block([[below2[0::2], below1[1::2]],
                           [jnp.broadcast_to(zero, below2[1::2].shape), below2[1::2]]])
        return pair, below

    def hessian(self, prep, z, lam):
        """(point blocks (n, 9, 9), None, the segments' local reduced Hessians (K, 9 n, 9 n),
        the windows of T (`_windows`))."""
        Tw = self._windows(prep)
        blocks = point_hessians(z, lam, self.ocp, self.grid).reshape(self.K, self.nk, 9, 9)
        local = jnp.einsum("sixk,sixl->skl", Tw, jnp.einsum("sixy,siyl->sixl", blocks, Tw))
        return blocks.reshape(-1, 9, 9), None, local, Tw

    def solve(self, prep, H, g, c, dw, dc):
        """`CondensedSecondOrder.solve` with T as a linear map and the band factored block by
        block (NaN, so not ok, where the reduced Hessian is not positive definite)."""
        del dc
        _, _, local, Tw = H
        zero_r = self._zero_r(c.dtype)
        w0 = jnp.zeros(self.live.size, c.dtype)
        _, T_vjp = jax.vjp(lambda w: self._step(prep, w, zero_r), w0)
        p0, p0_vjp = jax.vjp(lambda r: self._particular(prep, r), c)
        local = jax.lax.cond(dw > 0, lambda: local + dw * jnp.einsum("sixk,sixl->skl", Tw, Tw),
                             lambda: local)
        rhs = -T_vjp(g + self._hessian_times(H, dw, p0))[0]
        pair, below = self._band(local)
        m = pair.shape[0]
        rhs = jnp.pad(rhs, (0, m * pair.shape[1] - rhs.size)).reshape(m, -1)
        w = block_tridiagonal_solve(pair, below, rhs).ravel()[:self.live.size]
        p = self._step(prep, w, zero_r) + p0
        lam_new = p0_vjp(g + self._hessian_times(H, dw, p))[0]
        return p, lam_new, jnp.all(jnp.isfinite(p)) & jnp.all(jnp.isfinite(lam_new))


def condensed_linear_algebra(ocp, grid, z_ref=None):
    """The condensed linear algebra for (ocp, grid): `SegmentedCondensed` where
    `segments_apply`, else `CondensedSecondOrder` (a `linear_algebra` for `newton_kkt`)."""
    cls = SegmentedCondensed if segments_apply(ocp, grid) else CondensedSecondOrder
    return cls(ocp, grid, z_ref)
