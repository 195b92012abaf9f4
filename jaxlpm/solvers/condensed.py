"""Condensed Newton-KKT linear algebra for the LVLH transfer on LGL grids.

The LGL transcription of `jaxlpm.problems.relative` (models "two-body" and "j2", every thrust
axis present, fixed boundary states) collocates x = [r, v] at all N + 1 points with
dr/ds = q v and dv/ds = d(s, x) + q u (d the drift, q = n dt/ds). Its linearised defects

    D dR - h q dV = -c_r,      D dV - h (dd/dx) dx - h q dU = -c_v       (h = (s_f - s_0) / 2)

are solved, for any displacement dR of the positions, by dV and then dU point by point (the
inverse-dynamics elimination `kkt_law` uses for the linear model, Mei 2010 eq. 12). The
boundary rows fix dR_0, dR_N and two rows of D dR per axis, so with the interior positions
written as dR_int = (particular) + Z y, Z an orthonormal basis of the null space of
D[[0, N], 1:N], every step satisfying the linearised constraints is

    p = T y + p_0(c),      y in R^{3 (N - 3)},

and the Newton-KKT step of `newton_kkt` is the null-space solution (Nocedal & Wright 2006,
§16.2): (T^T (H + dw I) T) y = -T^T (g + (H + dw I) p_0), with H the Lagrangian Hessian, block
diagonal over the points. Its multipliers follow from the stationarity rows A^T lambda =
-(g + (H + dw I) p) in the same order (dU gives the velocity-defect multipliers, dV the
position-defect ones, the interior dR rows the two end ones by least squares, the end rows the
boundary multipliers). At N = 64 that is a 183 x 183 Cholesky factorisation, whose success is
exactly the KKT matrix's correct inertia (a positive definite reduced Hessian), in place of the
dense 987 x 987 LU. For a given (z, lambda) the step is `DenseKKT`'s; the first multiplier
estimate (the formulas above for g, not least squares) and the second-order correction (the
particular solution p_0, not the least-norm one) differ, so iterates differ while converging to
the same KKT point.
"""

import jax
import jax.numpy as jnp

from ..problems.transcription import (collocation_s, n_boundary, objective, point_hessians,
                                      point_indices, unpack)


class CondensedLVLH:
    """`newton_kkt`'s linear algebra (see `DenseKKT` for the interface) for `transfer_ocp`'s
    LVLH transcription on an LGL grid with every thrust axis (the caller checks)."""

    def __init__(self, ocp, grid):
        self.ocp, self.grid = ocp, grid
        self.h = 0.5 * (ocp.sf - ocp.s0)
        self.q = ocp.node_data[-1]
        Qc, Rc = jnp.linalg.qr(grid.D[jnp.array([0, -1])][:, 1:-1].T, mode="complete")
        self.Q, self.R1 = Qc, Rc[:2, :2]
        self.idx = point_indices(ocp, grid)              # (n, 9) positions of (x_i, u_i) in z

    def _drift_jacobians(self, z):
        """dd/dx at the points, (n, 3, 6)."""
        ocp = self.ocp
        X, _, _ = unpack(z, ocp, self.grid)
        zero = jnp.zeros(ocp.n_u, z.dtype)
        drift = lambda si, x, d: ocp.dynamics(si, x, zero, d, ocp.params)[3:]
        return jax.vmap(jax.jacfwd(drift, argnums=1))(collocation_s(ocp, self.grid), X,
                                                      ocp.node_data)

    def _displacement(self, y, r, Gd):
        """The p (flat, like z) with A p = -r whose interior position displacement has
        null-space coordinates y (N - 3, 3)."""
        D, h, q, n = self.grid.D, self.h, self.q[:, None], self.grid.n
        c = r[:6 * n].reshape(n, 6)
        b = r[6 * n:]
        dR0, dRN = -b[0:3], -b[6:9]
        e0 = -h * q[0] * b[3:6] - c[0, :3]                # (D dR)_0 that makes dV_0 = -b_v0
        eN = -h * q[-1] * b[9:12] - c[-1, :3]
        rhs = jnp.stack([e0 - D[0, 0] * dR0 - D[0, -1] * dRN,
                         eN - D[-1, 0] * dR0 - D[-1, -1] * dRN])
        interior = (self.Q[:, :2] @ jax.scipy.linalg.solve_triangular(self.R1.T, rhs, lower=True)
                    + self.Q[:, 2:] @ y)
        dR = jnp.concatenate([dR0[None], interior, dRN[None]])
        dV = (D @ dR + c[:, :3]) / (h * q)
        dX = jnp.concatenate([dR, dV], axis=1)
        dU = (D @ dV - h * jnp.einsum("iab,ib->ia", Gd, dX) + c[:, 3:]) / (h * q)
        return jnp.concatenate([dX.ravel(), dU.ravel()])

    def _multipliers(self, r_pts, Gd):
        """lambda with A^T lambda = -r (r at the points, (n, 9)), exact in every row but the
        interior position rows (least squares there; consistent at a KKT step)."""
        D, h, q = self.grid.D, self.h, self.q[:, None]
        r_R, r_V, r_U = r_pts[:, :3], r_pts[:, 3:6], r_pts[:, 6:]
        beta = r_U / (h * q)                                       # U rows
        a = h * jnp.einsum("iab,ia->ib", Gd, beta)                 # h (dd/dx)^T beta, (n, 6)
        a_r, a_v = a[:, :3], a[:, 3:]
        Dtb = D.T @ beta
        alpha = (Dtb - a_v + r_V) / (h * q)                        # V rows (interior)
        rhs = -r_R[1:-1] + a_r[1:-1] - D[1:-1, 1:-1].T @ alpha[1:-1]
        ends = jax.scipy.linalg.solve_triangular(self.R1, self.Q[:, :2].T @ rhs, lower=False)
        alpha = alpha.at[0].set(ends[0]).at[-1].set(ends[1])
        nu_r = -r_R - D.T @ alpha + a_r                            # R rows at the ends
        nu_v = -r_V - Dtb + h * q * alpha + a_v                    # V rows at the ends
        defects = jnp.concatenate([alpha, beta], axis=1).ravel()
        return jnp.concatenate([defects, nu_r[0], nu_v[0], nu_r[-1], nu_v[-1]])

    def prepare(self, z, lam):
        Gd = self._drift_jacobians(z)
        ny = 3 * (self.grid.n - 4)
        zero_r = jnp.zeros(6 * self.grid.n + n_boundary(self.ocp, self.grid), z.dtype)
        T = jax.jacfwd(lambda y: self._displacement(y.reshape(-1, 3), zero_r, Gd))(
            jnp.zeros(ny, z.dtype))
        return Gd, T[self.idx]                                      # T: (n, 9, ny)

    def hessian(self, prep, z, lam):
        return point_hessians(z, lam, self.ocp, self.grid)

    def hessian_scale(self, H):
        return jnp.max(jnp.abs(jnp.diagonal(H, axis1=1, axis2=2)))

    def solve(self, prep, H, g, c, dw, dc):
        """(p, lambda+, ok): the null-space step; ok when the reduced Hessian's Cholesky
        factor (and so p) is finite, i.e. the KKT matrix has the right inertia."""
        del dc                              # the constraint rows are eliminated exactly
        Gd, T = prep
        Hd = H + dw * jnp.eye(H.shape[-1], dtype=H.dtype)
        p0 = self._displacement(jnp.zeros((self.grid.n - 4, 3), g.dtype), c, Gd)
        g_pts, p0_pts = g[self.idx], p0[self.idx]
        M = jnp.einsum("iak,iab,ibl->kl", T, Hd, T)
        rhs = -jnp.einsum("iak,ia->k", T, g_pts + jnp.einsum("iab,ib->ia", Hd, p0_pts))
        y = jax.scipy.linalg.cho_solve((jnp.linalg.cholesky(M), True), rhs)
        p_pts = jnp.einsum("iak,k->ia", T, y) + p0_pts
        p = jnp.zeros_like(g).at[self.idx].set(p_pts)
        lam_new = self._multipliers(g_pts + jnp.einsum("iab,ib->ia", Hd, p_pts), Gd)
        return p, lam_new, jnp.all(jnp.isfinite(p)) & jnp.all(jnp.isfinite(lam_new))

    def correction(self, prep, r):
        """A d with A d = -r (interior null-space part zero; not least-norm)."""
        Gd, _ = prep
        return self._displacement(jnp.zeros((self.grid.n - 4, 3), r.dtype), r, Gd)

    def first_multipliers(self, z):
        """The multipliers that make the stationarity rows vanish for the gradient at z."""
        g = jax.grad(lambda v: objective(v, self.ocp, self.grid))(z)
        return self._multipliers(g[self.idx], self._drift_jacobians(z))
