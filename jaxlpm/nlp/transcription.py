"""Pseudospectral transcription of an `OptimalControlProblem` into NLP functions of one vector.

Decision vector z = [X (state rows, n_x each), U (collocation points, n_u each), (sf)].
State rows by scheme (tau in [-1, 1], s = s0 + h (tau + 1), h = (sf - s0) / 2):
  LGL  the N + 1 LGL points, all collocated (Fahroo & Ross 2001; Mei 2010 eq. 12)
  LG   [-1, K Gauss points, +1]; the state polynomial lives on [-1, Gauss points] and the final
       state is tied to it by Gauss quadrature, X_f = X_0 + h sum_k w_k F_k (Benson et al. 2006)
  LGR  [K Radau points (-1 included), +1], the final point not collocated (Garg et al. 2010)
Equality constraints: defects D X - h F(X_c, U) at the collocation points (n, n_x), for LG the
quadrature row, then the boundary residuals b(x0, xf, sf). Cost: h sum_i w_i L_i + phi.
Path constraints g <= 0, h = 0 are imposed at the collocation points (where the controls live),
the final-s bounds on sf; with a `PathPenalty` (the augmented-Lagrangian solver's inner
problems) the objective carries their augmented-Lagrangian terms.

On a `PaddedGrid` (lgl(n) held at a fixed capacity, `jaxlpm.collocation.padded`: one
compiled program for every n up to it) the padding's unknowns are pinned so that the KKT
matrix stays regular and the grid's own solution is unchanged: a padding row's defect is
X_pad - X_last (its dynamics are not evaluated into any row), its control enters the cost as
|U_pad|^2 / 2 (it solves to 0), and its path values are constants (H = 0, G = -1), so its
multipliers are 0 at every KKT point.

Costate estimates (Garg et al. 2010, Benson et al. 2006): with the Lagrangian J + Lambda^T c,
lambda(tau_i) = -Lambda_i / w_i at the collocation points (LG: -(Lambda_i / w_i + Lambda_F),
Lambda_F the quadrature row's multiplier). They converge for LG and LGR; LGL's do not converge
at every node (Fahroo & Ross 2001 need a closure condition at the end points).
"""

import jax
import jax.numpy as jnp
import numpy as np

from ..collocation.padded import padding
from ..collocation.segments import Mesh
from .ocp import OptimalControlProblem


def n_state_rows(grid) -> int:
    """Number of state rows in z for the grid's scheme (a `Mesh`: its `n_rows`)."""
    if isinstance(grid, Mesh):
        return grid.n_rows
    return grid.n + {"LGL": 0, "LG": 2, "LGR": 1}[grid.scheme]


def state_tau(grid):
    """tau of the state rows: LGL points; LG [-1, points, 1]; LGR [points, 1]; a `Mesh`'s
    `state_tau`."""
    if isinstance(grid, Mesh):
        return grid.state_tau
    one = jnp.ones(1, grid.points.dtype)
    if grid.scheme == "LGL":
        return grid.points
    if grid.scheme == "LG":
        return jnp.concatenate([-one, grid.points, one])
    return jnp.concatenate([grid.points, one])


def collocated_rows(grid):
    """The state rows at the collocation points: a slice, or a `Mesh`'s index array."""
    if isinstance(grid, Mesh):
        return grid.collocated
    return {"LGL": slice(None), "LG": slice(1, -1), "LGR": slice(None, -1)}[grid.scheme]


def support_rows(grid):
    """Slice of the state rows on which the state polynomial (and D) is defined (a `Mesh`:
    every row)."""
    if isinstance(grid, Mesh):
        return slice(None)
    return {"LGL": slice(None), "LG": slice(None, -1), "LGR": slice(None)}[grid.scheme]


def differentiate(grid, values):
    """D @ values[support rows] for values (n_state_rows, ...): the derivative in tau at the
    collocation points of the state polynomial through them (a `Mesh` segment by segment)."""
    if isinstance(grid, Mesh):
        return grid.differentiate(values)
    return grid.D @ values[support_rows(grid)]


def quadrature_rows(grid):
    """(E (q, rows), W (q, n)) of the Gauss quadrature conditions E X - h W F = 0: LG's
    X_f - X_0 - h sum_k w_k F_k, one per segment of an `LGMesh`; None for LGL and LGR."""
    if isinstance(grid, Mesh):
        return grid.quadrature
    if grid.scheme != "LG":
        return None
    E = jnp.zeros((1, grid.n + 2), grid.points.dtype).at[0, 0].set(-1.0).at[0, -1].set(1.0)
    return E, jnp.asarray(grid.weights)[None]


def linkage_rows(grid):
    """L (p, rows) of the linkage conditions L X = 0 (an `LGLMesh`'s state continuity at its
    interior breaks), or None."""
    return grid.linkage if isinstance(grid, Mesh) else None


def n_extra_rows(grid) -> int:
    """Equality rows between the collocation defects and the boundary residuals, per state
    component: the quadrature rows and the linkage rows."""
    quad, link = quadrature_rows(grid), linkage_rows(grid)
    return (0 if quad is None else quad[0].shape[0]) + (0 if link is None else link.shape[0])


def n_variables(ocp: OptimalControlProblem, grid) -> int:
    return n_state_rows(grid) * ocp.n_x + grid.n * ocp.n_u + int(ocp.free_final)


def pack(X, U, sf, ocp: OptimalControlProblem):
    """z from state rows X (n_rows, n_x), controls U (n, n_u) and sf (used if free_final)."""
    parts = [X.reshape(-1), U.reshape(-1)]
    if ocp.free_final:
        parts.append(jnp.reshape(sf, (1,)))
    return jnp.concatenate(parts)


def unpack(z, ocp: OptimalControlProblem, grid):
    """(X (n_rows, n_x), U (n, n_u), sf) from z."""
    nx = n_state_rows(grid) * ocp.n_x
    nu = grid.n * ocp.n_u
    X = z[:nx].reshape(-1, ocp.n_x)
    U = z[nx:nx + nu].reshape(grid.n, ocp.n_u)
    sf = z[nx + nu] if ocp.free_final else ocp.sf
    return X, U, sf


def collocation_s(ocp: OptimalControlProblem, grid, sf=None):
    """Independent variable at the collocation points."""
    sf = ocp.sf if sf is None else sf
    return ocp.s0 + 0.5 * (sf - ocp.s0) * (grid.points + 1.0)


def state_s(ocp: OptimalControlProblem, grid, sf=None):
    """Independent variable at the state rows (`state_tau`)."""
    sf = ocp.sf if sf is None else sf
    return ocp.s0 + 0.5 * (sf - ocp.s0) * (state_tau(grid) + 1.0)


def _pointwise(fun, ocp, grid, X, U, sf):
    """fun(s_i, x_i, u_i, data_i, params) at every collocation point."""
    s = collocation_s(ocp, grid, sf)
    Xc = X[collocated_rows(grid)]
    data_axis = None if ocp.node_data is None else 0
    return jax.vmap(fun, in_axes=(0, 0, 0, data_axis, None))(s, Xc, U, ocp.node_data, ocp.params)


def objective(z, ocp: OptimalControlProblem, grid):
    """J = h sum_i w_i L(s_i, x_i, u_i) + phi(x0, xf, sf) (+ the `PathPenalty` terms)."""
    X, U, sf = unpack(z, ocp, grid)
    h = 0.5 * (sf - ocp.s0)
    J = h * jnp.dot(grid.weights, _pointwise(ocp.running_cost, ocp, grid, X, U, sf))
    if ocp.terminal_cost is not None:
        J = J + ocp.terminal_cost(X[0], X[-1], sf, ocp.params)
    pad = padding(grid)
    if pad is not None:
        J = J + 0.5 * jnp.sum(jnp.where(pad[:, None], U, 0.0) ** 2)
    if ocp.penalty is not None:
        G, H, B = path_values(z, ocp, grid)
        P = ocp.penalty
        J = J + (jnp.sum(phr_inequality(G, P.inequality, P.rho))
                 + jnp.sum(phr_equality(H, P.equality, P.rho))
                 + jnp.sum(phr_inequality(B, P.bounds, P.rho)))
    return J


def phr_inequality(g, mu, rho):
    """Augmented-Lagrangian term of g <= 0 with multiplier mu >= 0 (elementwise):
    [max(0, mu + rho g)^2 - mu^2] / (2 rho) (Nocedal & Wright 2006, eq. 17.65)."""
    return (jnp.maximum(mu + rho * g, 0.0) ** 2 - mu**2) / (2.0 * rho)


def phr_equality(h, nu, rho):
    """Augmented-Lagrangian term of h = 0 with multiplier nu: nu h + rho h^2 / 2 (eq. 17.39)."""
    return nu * h + 0.5 * rho * h**2


def _point_values(fun, ocp, grid, X, U, sf, fill=0.0):
    """fun's values (n, n_fun) at the collocation points; (n, 0) when fun is None; `fill` on
    a `PaddedGrid`'s padding."""
    if fun is None:
        return jnp.zeros((grid.n, 0), X.dtype)
    return _live(grid, _pointwise(fun, ocp, grid, X, U, sf).reshape(grid.n, -1), fill)


def _live(grid, values, fill=0.0):
    """values (n, ...) per collocation point with a `PaddedGrid`'s padding rows set to
    `fill` (no derivative flows from them); values unchanged on any other grid."""
    pad = padding(grid)
    if pad is None:
        return values
    return jnp.where(pad.reshape(-1, *(1,) * (values.ndim - 1)), fill, values)


def path_values(z, ocp: OptimalControlProblem, grid):
    """(G (n, n_g) <= 0, H (n, n_h) = 0, B (2,) or (0,) <= 0): the path inequality and
    equality values at the collocation points and the final-s bounds [sf_min - sf, sf - sf_max]
    (an infinite bound gives the constant -1: never active, and no inf in any derivative)."""
    X, U, sf = unpack(z, ocp, grid)
    G = _point_values(ocp.path, ocp, grid, X, U, sf, fill=-1.0)
    H = _point_values(ocp.path_equality, ocp, grid, X, U, sf)
    if ocp.final_bounds is None:
        B = jnp.zeros(0, z.dtype)
    else:
        B = jnp.stack([ocp.final_bounds[0] - sf, sf - ocp.final_bounds[1]])
        B = jnp.where(jnp.isfinite(B), B, -1.0)
    return G, H, B


def defects(z, ocp: OptimalControlProblem, grid):
    """Collocation defects D X - h F (n, n_x), then the quadrature rows E X - h W F (LG: one
    per segment) and the linkage rows L X (an `LGLMesh`'s interior breaks), (q + p, n_x)."""
    X, U, sf = unpack(z, ocp, grid)
    h = 0.5 * (sf - ocp.s0)
    F = _live(grid, _pointwise(ocp.dynamics, ocp, grid, X, U, sf))
    rows = [differentiate(grid, X) - h * F]
    pad = padding(grid)
    if pad is not None:
        rows[0] = rows[0] + jnp.where(pad[:, None], X - X[-1], 0.0)
    quad, link = quadrature_rows(grid), linkage_rows(grid)
    if quad is not None:
        E, W = quad
        rows.append(E @ X - h * (W @ F))
    if link is not None:
        rows.append(link @ X)
    return jnp.concatenate(rows)


def equality(z, ocp: OptimalControlProblem, grid):
    """All equality constraints c(z) = 0: defects (row-major) then boundary residuals."""
    X, _, sf = unpack(z, ocp, grid)
    bc = jnp.atleast_1d(ocp.boundary(X[0], X[-1], sf, ocp.params))
    return jnp.concatenate([defects(z, ocp, grid).reshape(-1), bc])


def n_boundary(ocp: OptimalControlProblem, grid) -> int:
    """Number of boundary residuals b(x0, xf, sf)."""
    x = jax.ShapeDtypeStruct((ocp.n_x,), jnp.float64)
    return jax.eval_shape(lambda a, b: jnp.atleast_1d(ocp.boundary(a, b, ocp.sf, ocp.params)),
                          x, x).shape[0]


def point_indices(ocp, grid):
    """(n, n_x + n_u) positions in z of each collocation point's (x_i, u_i)."""
    rows = np.arange(n_state_rows(grid))[collocated_rows(grid)]
    points = jnp.arange(grid.n)
    xi = jnp.asarray(rows)[:, None] * ocp.n_x + jnp.arange(ocp.n_x)[None]
    ui = (n_state_rows(grid) * ocp.n_x + points[:, None] * ocp.n_u
          + jnp.arange(ocp.n_u)[None])
    return jnp.concatenate([xi, ui], axis=1)


def _end_indices(ocp, grid):
    """Positions in z of x0 then xf."""
    last = n_state_rows(grid) - 1
    return jnp.concatenate([jnp.arange(ocp.n_x), last * ocp.n_x + jnp.arange(ocp.n_x)])


def pointwise_jacobian(ocp, grid, X, U, sf):
    """dF/d(x, u) at every collocation point, (n, n_x, n_x + n_u)."""
    s = collocation_s(ocp, grid, sf)
    Xc = X[collocated_rows(grid)]
    data_axis = None if ocp.node_data is None else 0

    def jac(si, x, u, d):
        return jax.jacfwd(lambda v: ocp.dynamics(si, v[:ocp.n_x], v[ocp.n_x:], d, ocp.params))(
            jnp.concatenate([x, u]))

    return jax.vmap(jac, in_axes=(0, 0, 0, data_axis))(s, Xc, U, ocp.node_data)


def equality_jacobian(z, ocp: OptimalControlProblem, grid):
    """dc/dz assembled from the collocation structure: kron(D, I) on the state polynomial,
    -h dF/d(x_i, u_i) blocks at each point, the LG quadrature row, the boundary rows on
    (x0, xf), and (free final s) the dense sf column from one forward-mode derivative."""
    X, U, sf = unpack(z, ocp, grid)
    n_x, n = ocp.n_x, z.size
    h = 0.5 * (sf - ocp.s0)
    J = -h * _live(grid, pointwise_jacobian(ocp, grid, X, U, sf))  # (n_pts, n_x, n_x + n_u)
    idx = point_indices(ocp, grid)
    n_def = grid.n * n_x
    rows_i = jnp.arange(n_def).reshape(grid.n, n_x)
    A = jnp.zeros((n_def, n), z.dtype)
    support = support_rows(grid)
    n_support = X[support].shape[0]
    A = A.at[:, :n_support * n_x].set(jnp.kron(grid.D, jnp.eye(n_x, dtype=z.dtype)))
    A = A.at[rows_i[:, :, None], idx[:, None, :]].add(J)
    pad = padding(grid)
    if pad is not None:                          # the padding's rows X_pad - X_last
        on = pad[:, None].astype(z.dtype)
        A = A.at[rows_i, idx[:, :n_x]].add(on).at[rows_i, idx[-1:, :n_x]].add(-on)
    blocks = [A]
    eye = jnp.eye(n_x, dtype=z.dtype)
    n_states = n_state_rows(grid) * n_x
    quad, link = quadrature_rows(grid), linkage_rows(grid)
    if quad is not None:
        E, W = quad
        Q = jnp.zeros((E.shape[0], n_x, n), z.dtype)
        Q = Q.at[:, :, idx.reshape(-1)].add(
            jnp.einsum("ki,iab->kaib", W, J).reshape(E.shape[0], n_x, -1))
        Q = Q.reshape(-1, n).at[:, :n_states].add(jnp.kron(E, eye))
        blocks.append(Q)
    if link is not None:
        blocks.append(jnp.zeros((link.shape[0] * n_x, n), z.dtype).at[:, :n_states].set(
            jnp.kron(link, eye)))
    ends = _end_indices(ocp, grid)
    Jb = jax.jacfwd(lambda v: jnp.atleast_1d(ocp.boundary(v[:n_x], v[n_x:], sf, ocp.params)))(
        z[ends])
    blocks.append(jnp.zeros((Jb.shape[0], n), z.dtype).at[:, ends].set(Jb))
    A = jnp.concatenate(blocks)
    if ocp.free_final:
        e_sf = jnp.zeros(n, z.dtype).at[-1].set(1.0)
        col = jax.jvp(lambda v: equality(v, ocp, grid), (z,), (e_sf,))[1]
        A = A.at[:, -1].set(col)
    return A


def lagrangian(z, multipliers, ocp: OptimalControlProblem, grid):
    """f(z) + multipliers . c(z)."""
    return objective(z, ocp, grid) + jnp.dot(multipliers, equality(z, ocp, grid))


def point_hessians(z, multipliers, ocp: OptimalControlProblem, grid):
    """Per collocation point, the Hessian in (x_i, u_i) of h w_i L(x_i, u_i) - h mu_i . F(x_i,
    u_i) (mu_i = Lambda_i; LG: + w_i Lambda_F), plus a `PathPenalty`'s path terms:
    (n, n_x + n_u, n_x + n_u), at the positions `point_indices` of z."""
    X, U, sf = unpack(z, ocp, grid)
    n_x = ocp.n_x
    h = 0.5 * (sf - ocp.s0)
    n_def = grid.n * n_x
    mu = multipliers[:n_def].reshape(grid.n, n_x)
    quad = quadrature_rows(grid)
    if quad is not None:
        W = quad[1]
        mu = mu + W.T @ multipliers[n_def:n_def + W.shape[0] * n_x].reshape(-1, n_x)
    s = collocation_s(ocp, grid, sf)
    data_axis = None if ocp.node_data is None else 0

    P = ocp.penalty
    if P is None:
        pen_g = pen_h = jnp.zeros((grid.n, 0), z.dtype)
    else:
        pen_g, pen_h = P.inequality, P.equality
    pad = padding(grid)
    live = _live(grid, jnp.ones(grid.n, z.dtype))

    def point_block(si, x, u, d, mui, wi, gi, hi, li):
        def ell(v):
            xv, uv = v[:n_x], v[n_x:]
            val = h * (wi * ocp.running_cost(si, xv, uv, d, ocp.params)
                       - li * mui @ ocp.dynamics(si, xv, uv, d, ocp.params))
            if P is not None and ocp.path is not None:
                g = jnp.atleast_1d(ocp.path(si, xv, uv, d, ocp.params))
                val = val + li * jnp.sum(phr_inequality(g, gi, P.rho))
            if P is not None and ocp.path_equality is not None:
                e = jnp.atleast_1d(ocp.path_equality(si, xv, uv, d, ocp.params))
                val = val + li * jnp.sum(phr_equality(e, hi, P.rho))
            if pad is not None:                  # the padding's control cost |U_pad|^2 / 2
                val = val + 0.5 * (1.0 - li) * jnp.dot(uv, uv)
            return val
        return jax.hessian(ell)(jnp.concatenate([x, u]))

    return jax.vmap(point_block, in_axes=(0, 0, 0, data_axis, 0, 0, 0, 0, 0))(
        s, X[collocated_rows(grid)], U, ocp.node_data, mu, grid.weights, pen_g, pen_h, live)


def lagrangian_hessian(z, multipliers, ocp: OptimalControlProblem, grid):
    """Hessian of `lagrangian` in z from its separable pieces: the `point_hessians` blocks,
    the (x0, xf) block of the boundary and terminal terms, and with a free final s the dense sf
    row and column (one forward-over-reverse derivative). D X is linear: no contribution.
    A `PathPenalty`'s final-s term lives in the sf row and column."""
    _, _, sf = unpack(z, ocp, grid)
    n_x, n = ocp.n_x, z.size
    nu = multipliers[multipliers.size - n_boundary(ocp, grid):]
    blocks = point_hessians(z, multipliers, ocp, grid)
    idx = point_indices(ocp, grid)
    H = jnp.zeros((n, n), z.dtype).at[idx[:, :, None], idx[:, None, :]].add(blocks)

    def end_terms(v):
        val = jnp.dot(nu, jnp.atleast_1d(ocp.boundary(v[:n_x], v[n_x:], sf, ocp.params)))
        if ocp.terminal_cost is not None:
            val = val + ocp.terminal_cost(v[:n_x], v[n_x:], sf, ocp.params)
        return val

    ends = _end_indices(ocp, grid)
    H = H.at[ends[:, None], ends[None, :]].add(jax.hessian(end_terms)(z[ends]))
    if ocp.free_final:
        e_sf = jnp.zeros(n, z.dtype).at[-1].set(1.0)
        col = jax.jvp(lambda v: jax.grad(lagrangian)(v, multipliers, ocp, grid), (z,), (e_sf,))[1]
        H = H.at[:, -1].set(col).at[-1, :].set(col)
    return H


def costates(z, multipliers, ocp: OptimalControlProblem, grid):
    """Costate estimates lambda(s_i) (n, n_x) at the collocation points from the equality
    multipliers (see the module docstring); in the problem's units, per unit s. On an
    `LGMesh` each point takes its own segment's quadrature multiplier. On LGL the end points
    take the transversality conditions instead, lambda(s0) = -(db/dx0)^T nu and lambda(sf) =
    dphi/dxf + (db/dxf)^T nu (nu: the boundary multipliers), the closure that Fahroo & Ross's
    (2001) covector mapping needs there: the quadrature estimate is not consistent at the
    ends; on an `LGLMesh` both rows of an interior break take the same closure from its
    linkage condition X(b^-) - X(b^+) = 0, lambda(b^-) = lambda(b^+) = eta (its
    multiplier)."""
    n_x = ocp.n_x
    n_def = grid.n * n_x
    Lam = multipliers[:n_def].reshape(grid.n, n_x)
    weights = _live(grid, grid.weights, 1.0)         # a padding row's Lam is 0
    lam = -Lam / weights[:, None]
    quad, link = quadrature_rows(grid), linkage_rows(grid)
    if quad is not None:
        W = quad[1]
        Lam_q = multipliers[n_def:n_def + W.shape[0] * n_x].reshape(-1, n_x)
        lam = lam - (W.T @ Lam_q) / weights[:, None]
    if grid.scheme == "LGL":
        X, _, sf = unpack(z, ocp, grid)
        nu = multipliers[n_def + n_extra_rows(grid) * n_x:]

        def ends(x0, xf):
            phi = 0.0 if ocp.terminal_cost is None else ocp.terminal_cost(x0, xf, sf,
                                                                          ocp.params)
            return phi + nu @ jnp.atleast_1d(ocp.boundary(x0, xf, sf, ocp.params))

        d0, df = jax.grad(ends, argnums=(0, 1))(X[0], X[-1])
        lam = lam.at[0].set(-d0).at[-1].set(df)
        if link is not None:
            eta = multipliers[n_def:n_def + link.shape[0] * n_x].reshape(-1, n_x)
            m = grid.segment.n
            knots = np.arange(link.shape[0])
            lam = lam.at[knots * m + m - 1].set(eta).at[(knots + 1) * m].set(eta)
    return lam
