"""Condensed Newton-KKT linear algebra for fully actuated second-order problems.

For problems whose state is x = [r, v] (3 + 3) with dynamics

    dr/ds = q(s) v,      dv/ds = d(s, x) + b(s) u        (q, b scalars per point)

and fixed boundary states (the LVLH transfers of `jaxlpm.problems.energy_optimal` with every thrust
axis, the minimum-time HCW transfer of `jaxlpm.problems.min_time`), the linearised collocation
defects of every scheme

    D dR - h q dV = -c_r,      D dV - h (dd/dx) dx - h b dU = -c_v       (h = (s_f - s_0) / 2)

are solved, for any displacement dR of the positions, by dV and then dU point by point (the
inverse-dynamics elimination `kkt_law` uses for the linear model, Mei 2010 eq. 12). The
boundary rows fix dR and dV at the two ends; what is left is a few linear conditions per axis
on the interior positions (LGL: the two end velocities through rows of D; LGR: the initial
velocity; LG: the two quadrature rows), so with the interior positions written as a particular
solution plus Z y (Z an orthonormal basis of those conditions' null space), every step that
satisfies the linearised constraints is

    p = T [y; ds_f] + p_0(c)          (ds_f only with a free final s)

and the Newton-KKT step of `newton_kkt` is the null-space solution (Nocedal & Wright 2006,
§16.2): (T^T (H + dw I) T) [y; ds_f] = -T^T (g + (H + dw I) p_0), H the Lagrangian Hessian
(block diagonal over the points, plus the dense s_f row and column). Since A p_0(r) = -r for
every r, the multipliers of a consistent system A^T lambda = -(g + (H + dw I) p) are
lambda = p_0^T (g + (H + dw I) p), one reverse-mode pass through p_0. At N = 64 (LGL) that is a
183 x 183 Cholesky factorisation, whose success is exactly the KKT matrix's correct inertia (a
positive definite reduced Hessian), instead of the dense 987 x 987 LU.

Meshes (`jaxlpm.collocation.segments`; Garg et al. 2010's multi-interval methods): an
`LGRMesh` is an LGR grid whose D is block bidiagonal (the same conditions). An `LGMesh`'s
interior breaks are not collocated: the velocity at b_{k+1} follows from segment k's velocity
quadrature row with its defects substituted, dV(b_{k+1}) = dV_k(+1) + sum_i W_ki c_v,i -
quad_v,k (dV_k(+1) segment k's velocity polynomial at its end: sum_i W_ki (D dV)_i =
dV_k(+1) - dV(b_k) exactly), a recursion from the initial velocity; the conditions left are
every segment's position quadrature row and the last one's velocity row. An `LGLMesh`
collocates both copies of a break (one per segment): its conditions are the two end
velocities and the linkage rows, positions and velocities, at every interior break.

For a given (z, lambda) the step is `DenseKKT`'s; the first multiplier estimate (p_0^T g, not
least squares) and the second-order correction (p_0, not the least-norm one) differ, so
iterates differ while converging to the same KKT point.
"""

import jax
import jax.numpy as jnp
import numpy as np

from ..collocation.segments import Mesh
from ..linalg import cholesky_solve, complete_qr, triangular_solve
from .transcription import (collocated_rows, differentiate, equality, lagrangian,
                            n_state_rows, n_variables, objective, point_hessians,
                            point_indices, pointwise_jacobian, unpack)


_NO_VELOCITY = np.array([0, 1, 2, 6, 7, 8])      # the r and u rows of a point block (r, v, u)


def point_reduced_hessian(Tp, blocks):
    """sum_i Tp_i^T H_i Tp_i for point blocks H_i (n, 9, 9) over (r, v, u) and the matching
    rows Tp_i (n, 9, k) of T; where the velocity rows vanish at every point (velocity-linear
    dynamics and path terms: gravity, the LVLH frame's Coriolis term, HCW) only the position
    and control rows enter."""
    def over(rows):
        Tr = Tp[:, rows]
        return jnp.einsum("iak,ial->kl", Tr,
                          jnp.einsum("iab,ibl->ial", blocks[:, rows][:, :, rows], Tr))

    return jax.lax.cond(jnp.any(blocks[:, 3:6] != 0), lambda: over(slice(0, 9)),
                        lambda: over(_NO_VELOCITY))


class CondensedSecondOrder:
    """`newton_kkt`'s linear algebra (the interface of `DenseKKT`) for the problems above, on
    LGL, LG or LGR grids. The caller guarantees the structure (q, b and dd/dx are read off the
    dynamics' Jacobian at each point) and boundary rows x0 - x0*, xf - xf* with no terminal
    cost on the states.

    With a fixed final s, the null space and the directions' states depend on h, q and b
    alone (functions of s), not on z (on LG grids the quadrature rows' dd/dx terms cancel
    against the velocity defects': h (dd + b dU) = D dV + c_v): they are formed once, at
    z_ref (a point where the dynamics are defined; default z = 0), and each Newton iteration
    only adds the dd/dx terms to the controls' rows of T. Single grids and `LGRMesh`, `LGMesh`,
    `LGLMesh` meshes (module docstring)."""

    def __init__(self, ocp, grid, z_ref=None):
        self.ocp, self.grid = ocp, grid
        self.n_rows = n_state_rows(grid)
        self.free = bool(ocp.free_final)
        n_var = n_variables(ocp, grid)
        self.n_c = jax.eval_shape(lambda: equality(jnp.zeros(n_var), ocp, grid)).shape[0]
        self.idx = point_indices(ocp, grid)              # (n, 9) positions of (x_i, u_i) in z
        self._fixed = None
        if not self.free:
            z_ref = jnp.zeros(n_var) if z_ref is None else z_ref
            self._fixed = self._z_independent(self._coefficients(z_ref), z_ref.dtype)

    # ------------------------------------------------------------------ the linear maps
    def _coefficients(self, z):
        """(h, q, b, dd/dx (n, 3, 6), dc/ds_f or None) at z."""
        X, U, sf = unpack(z, self.ocp, self.grid)
        J = pointwise_jacobian(self.ocp, self.grid, X, U, sf)      # (n, 6, 9)
        a_sf = None
        if self.free:
            e_sf = jnp.zeros(z.size, z.dtype).at[-1].set(1.0)
            a_sf = jax.jvp(lambda v: equality(v, self.ocp, self.grid), (z,), (e_sf,))[1]
        return 0.5 * (sf - self.ocp.s0), J[:, 0, 3], J[:, 3, 6], J[:, 3:, :6], a_sf

    def _states(self, dR, r, coef):
        """dX (rows, 6) for position displacements dR (rows, 3): dV from the collocated
        position defects (linearised, right-hand side -r), at non-collocated rows from the
        boundary rows."""
        g = self.grid
        h, q = coef[:2]
        c_r = r[:6 * g.n].reshape(g.n, 6)[:, :3]
        bc = r[r.size - 12:]
        dV_c = (differentiate(g, dR) + c_r) / (h * q[:, None])
        dV = jnp.zeros((self.n_rows, 3), dR.dtype).at[collocated_rows(g)].set(dV_c)
        if g.scheme == "LG":
            dV = self._break_velocities(dV.at[0].set(-bc[3:6]), r).at[-1].set(-bc[9:12])
        elif g.scheme == "LGR":
            dV = dV.at[-1].set(-bc[9:12])
        return jnp.concatenate([dR, dV], axis=1)

    def _gauss_segments(self):
        """(K, the break rows (K + 1,), the quadrature weights (K, n_k)) of an LG grid (one
        segment) or `LGMesh`."""
        g = self.grid
        if isinstance(g, Mesh):
            k = g.n_segments
            return k, np.arange(k + 1) * (g.segment.n + 1), g.weights.reshape(k, -1)
        return 1, np.array([0, self.n_rows - 1]), jnp.asarray(g.weights)[None]

    def _break_velocities(self, dV, r):
        """dV with an `LGMesh`'s interior break velocities from the recursion of the module
        docstring (the Gauss points' and the first break's already set)."""
        k, breaks, W = self._gauss_segments()
        if k == 1:
            return dV
        g = self.grid
        n = g.segment.n
        end = g.segment.interpolate_state(jnp.eye(n + 1, dtype=dV.dtype), 1.0)   # (n + 1,)
        c_v = r[:6 * g.n].reshape(k, n, 6)[:, :, 3:]
        quad_v = r[6 * g.n:6 * g.n + 6 * k].reshape(k, 6)[:, 3:]
        correction = jnp.einsum("ki,kia->ka", W, c_v) - quad_v
        gauss = dV[:-1].reshape(k, n + 1, 3)[:, 1:]

        def step(v, seg):
            v_gauss, corr = seg
            v_next = end[0] * v + end[1:] @ v_gauss + corr
            return v_next, v_next

        _, inner = jax.lax.scan(step, dV[0], (gauss[:-1], correction[:-1]))
        return dV.at[breaks[1:-1]].set(inner)

    def _complete(self, dR, r, coef):
        """(dX (rows, 6), dU (n, 3), unmet conditions (k, 3)) for position displacements dR
        (rows, 3) with the ends already at the boundary values: `_states`, dU from the
        collocated velocity defects, and the linearised constraints not yet imposed."""
        g = self.grid
        h, q, b, Gd, _ = coef
        n = g.n
        c = r[:6 * n].reshape(n, 6)
        bc = r[r.size - 12:]
        col = collocated_rows(g)
        dX = self._states(dR, r, coef)
        dV = dX[:, 3:]
        dd = jnp.einsum("iab,ib->ia", Gd, dX[col])
        dU = (differentiate(g, dV) - h * dd + c[:, 3:]) / (h * b[:, None])
        if g.scheme == "LGL":
            unmet = jnp.stack([dV[0] + bc[3:6], dV[-1] + bc[9:12]])
            if isinstance(g, Mesh) and g.n_segments > 1:    # the linkage rows at the joins
                left, right = g.joins
                joins = dX[left] - dX[right] + r[6 * n:6 * n + 6 * left.size].reshape(-1, 6)
                unmet = jnp.concatenate([unmet, joins[:, :3], joins[:, 3:]])
        elif g.scheme == "LGR":
            unmet = (dV[0] + bc[3:6])[None]
        else:          # the quadrature rows, linearised: positions, and the last velocities
            k, breaks, W = self._gauss_segments()
            quad = r[6 * n:6 * n + 6 * k].reshape(k, 6)
            rates = jnp.concatenate([q[:, None] * dV[col], dd + b[:, None] * dU], axis=1)
            flow = h * jnp.einsum("ki,kia->ka", W, rates.reshape(k, -1, 6))
            rows = dX[breaks[1:]] - dX[breaks[:-1]] - flow + quad
            unmet = jnp.concatenate([rows[:, :3], rows[-1:, 3:]])
        return dX, dU, unmet

    def _ends(self, r, dtype):
        """dR with the end rows from the boundary rows (x0 - x0*, xf - xf*) and zero inside."""
        bc = r[r.size - 12:]
        return jnp.zeros((self.n_rows, 3), dtype).at[0].set(-bc[0:3]).at[-1].set(-bc[6:9])

    def _null_space(self, coef, dtype):
        """(Q1, R1, Z): QR of the unmet conditions' matrix C (linear in the interior
        positions, right-hand side 0) transposed: C^T = Q1 R1, Z spans C's null space."""
        m = self.n_rows - 2
        zero_r = self._zero_r(dtype)

        def unmet(v):
            dR = jnp.zeros((self.n_rows, 3), dtype).at[1:-1].set(v.reshape(m, 3))
            return self._complete(dR, zero_r, coef)[2].ravel()

        C = jax.jacrev(unmet)(jnp.zeros(3 * m, dtype))                 # (3k, 3m)
        Qc, Rc = complete_qr(C.T)
        k = C.shape[0]
        return Qc[:, :k], Rc[:k, :k], Qc[:, k:]

    def _step(self, basis, w, r):
        """The z-shaped step (ds_f last if free) with A p = -r whose interior positions have
        null-space coordinates y = w[:ny] (and ds_f = w[-1] if free): the affine map T w +
        p_0(r)."""
        coef, (Q1, R1, Z), _ = basis
        dtype = r.dtype
        dsf = w[-1] if self.free else 0.0
        if self.free:
            r = r + dsf * coef[4]
        m = self.n_rows - 2
        dR = self._ends(r, dtype)
        e = -self._complete(dR, r, coef)[2].ravel()
        dR_int = Q1 @ triangular_solve(R1.T, e, lower=True) + Z @ w[:Z.shape[1]]
        dX, dU, _ = self._complete(dR.at[1:-1].set(dR_int.reshape(m, 3)), r, coef)
        parts = [dX.ravel(), dU.ravel()]
        if self.free:
            parts.append(jnp.reshape(dsf, (1,)))
        return jnp.concatenate(parts)

    def _particular(self, basis, r):
        """p_0(r): A p_0 = -r (interior null-space coordinates and ds_f zero)."""
        return self._step(basis, jnp.zeros(basis[1][2].shape[1] + int(self.free), r.dtype), r)

    def _zero_r(self, dtype):
        return jnp.zeros(self.n_c, dtype)

    def _directions(self, coef, Z, dtype):
        """The null-space directions' dX (rows, 6, n_y) and D dV / (h b) (n, 3, n_y): the parts
        of T that do not involve dd/dx (dU = D dV / (h b) - (dd/dx) dX / b)."""
        g = self.grid
        h, _, b = coef[:3]
        zero_r = self._zero_r(dtype)
        m = self.n_rows - 2

        def direction(dR_int):
            dR = jnp.zeros((self.n_rows, 3), dtype).at[1:-1].set(dR_int.reshape(m, 3))
            dX = self._states(dR, zero_r, coef)
            return dX, differentiate(g, dX[:, 3:]) / (h * b[:, None])

        return jax.vmap(direction, out_axes=-1)(Z.T)

    def _z_independent(self, coef, dtype):
        null = self._null_space(coef, dtype)
        return null, self._directions(coef, null[2], dtype)

    def _basis(self, z):
        """(coefficients, null space (Q1, R1, Z), directions) at z."""
        coef = self._coefficients(z)
        fixed = self._z_independent(coef, z.dtype) if self._fixed is None else self._fixed
        return (coef,) + fixed

    # ------------------------------------------------------------------ the interface
    def prepare(self, z, lam):
        """The null-space basis at z (the second-order correction needs it on every pass)."""
        return self._basis(z)

    def _null_space_map(self, basis, dtype):
        """T = d p / d w (n_var, n_w): the steps of the null-space directions (and ds_f)."""
        coef, _, (dX, dU_D) = basis
        b, Gd = coef[2], coef[3]
        k = dX.shape[-1]
        dd = jnp.einsum("iab,ibk->iak", Gd, dX[collocated_rows(self.grid)])
        dU = dU_D - dd / b[:, None, None]
        T = jnp.concatenate([dX.reshape(-1, k), dU.reshape(-1, k)]
                            + [jnp.zeros((1, k), dtype)] * self.free)
        if self.free:                        # the ds_f column
            e_sf = jnp.zeros(k + 1, dtype).at[-1].set(1.0)
            T = jnp.concatenate([T, self._step(basis, e_sf, self._zero_r(dtype))[:, None]],
                                axis=1)
        return T

    def hessian(self, prep, z, lam):
        """(point blocks (n, 9, 9), s_f column of the Lagrangian Hessian or None, the reduced
        Hessian T^T H T (`point_reduced_hessian`), T)."""
        T = self._null_space_map(prep, z.dtype)
        blocks = point_hessians(z, lam, self.ocp, self.grid)
        M = point_reduced_hessian(T[self.idx], blocks)
        col = None
        if self.free:
            e_sf = jnp.zeros(z.size, z.dtype).at[-1].set(1.0)
            col = jax.jvp(lambda v: jax.grad(lagrangian)(v, lam, self.ocp, self.grid), (z,),
                          (e_sf,))[1]
            cross = T[:-1].T @ col[:-1]
            M = M + jnp.outer(cross, T[-1]) + jnp.outer(T[-1], cross) \
                + col[-1] * jnp.outer(T[-1], T[-1])
        return blocks, col, M, T

    def hessian_scale(self, H):
        blocks, col = H[:2]
        scale = jnp.max(jnp.abs(jnp.diagonal(blocks, axis1=1, axis2=2)))
        return scale if col is None else jnp.maximum(scale, jnp.abs(col[-1]))

    def _hessian_times(self, H, dw, p):
        """(H + dw I) p for the structured H."""
        blocks, col = H[:2]
        out = dw * p
        out = out.at[self.idx].add(jnp.einsum("iab,ib->ia", blocks, p[self.idx]))
        if col is not None:
            out = out + col * p[-1]
            out = out.at[-1].add(col[:-1] @ p[:-1])
        return out

    def solve(self, prep, H, g, c, dw, dc):
        """(p, lambda+, ok): the null-space step; ok when the reduced Hessian's Cholesky
        factor (and so p) is finite, i.e. the KKT matrix has the right inertia."""
        del dc                              # the constraint rows are eliminated exactly
        T = H[3]
        p0, p0_vjp = jax.vjp(lambda r: self._particular(prep, r), c)
        M = jax.lax.cond(dw > 0, lambda: H[2] + dw * (T.T @ T), lambda: H[2])
        w = cholesky_solve(M, -T.T @ (g + self._hessian_times(H, dw, p0)))
        p = T @ w + p0
        lam_new = p0_vjp(g + self._hessian_times(H, dw, p))[0]
        return p, lam_new, jnp.all(jnp.isfinite(p)) & jnp.all(jnp.isfinite(lam_new))

    def correction(self, prep, r):
        """A d with A d = -r (not least-norm)."""
        return self._particular(prep, r)

    def first_multipliers(self, z):
        """p_0^T grad f: exact multipliers wherever the stationarity rows allow."""
        g = jax.grad(lambda v: objective(v, self.ocp, self.grid))(z)
        basis = self._basis(z)
        c = equality(z, self.ocp, self.grid)
        return jax.vjp(lambda r: self._particular(basis, r), c)[1](g)[0]
