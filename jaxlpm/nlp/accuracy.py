"""A-posteriori error estimate of a collocated solution between its collocation points (the
relative-error estimate of GPOPS-II: Patterson, Hager & Rao 2015, "A ph mesh refinement method
for optimal control", Optim. Control Appl. Meth. 36, §3; Liu, Hager & Rao 2015, "Adaptive mesh
refinement method for optimal control using nonsmoothness detection and mesh size reduction",
J. Franklin Inst. 352, §3).

On every piece [b_k, b_{k+1}] of the check mesh (`check_mesh`: each segment of the solution's
grid, a single grid being one segment on [-1, 1], cut into pieces of about 5 collocation
points) take m = 12 Legendre-Gauss-Radau check points tau_kj (tau_k0 = b_k), evaluate the
solution's state polynomial X(tau) and control interpolant U(tau) there, and integrate the
state derivative they imply from the segment's start with the m-point integration matrix A
(A_ij = int_{-1}^{tau_i} l_j) and, to the segment's end, the Radau quadrature:

    Xhat_kj = X(b_k) + h_k sum_l A_jl F(s_kl, X(tau_kl), U(tau_kl)),   j = 1 .. m - 1,
    Xhat_k,end = X(b_k) + h_k sum_l w_l F(s_kl, X(tau_kl), U(tau_kl))

(h_k the segment's half length in s). E = Xhat - X at those m rows is how far the state
polynomial is from the flow of its own control within the segment: zero at the collocation
points of an exact solve, and as small as the grid resolves the solution elsewhere. The
relative error of a segment is max_{i,j} |E_kji| / (1 + max_j |X_i(tau_kj)|) (Patterson et al.,
eq. 38), i over the state components in the problem's (nondimensional) units.

`collocation_defects` alone measures each segment from the polynomial's own value at its
start, so it cannot see how an error made early grows along the transfer (a velocity error
of a long relative transfer becomes a position error that drifts). `check_flight` therefore
also flies the solution's control on the check mesh: per segment, from the flight's state at
the segment's start, the collocation equations of the initial-value problem
Y_j = Y_0 + h_k sum_l A_jl F(s_kl, Y_l, U(tau_kl)) solved by Newton's method (started from
the polynomial), then carried to the segment's end by the quadrature. Its largest distance from
the polynomial, over the check rows, estimates the miss of the solution flown by an
independent integrator (what `jaxlpm.verify.fly` measures) wherever the check mesh resolves
the flight: it has 2.4 check points per collocation point.

Linear dynamics whose transition matrix is known in closed form need no Newton systems:
`separable_flight` flies them by the variation of constants, with the quadratures above.

The check points get their own per-point data (a chief's ephemeris): the caller builds the
problem on the check mesh (`check_mesh`) so that `node_data` sits at its points.
"""

from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from ..collocation import Grid, interpolation_matrix
from ..collocation.padded import PaddedGrid
from ..collocation.segments import LGRMesh, Mesh, lgr_mesh
from ..linalg import entries_at, entries_mv, entries_sum, lu_solve
from .transcription import support_rows

POINTS_PER_PIECE = 5   # a check piece spans about this many of a segment's collocation points
CHECK_POINTS = 12      # Radau check points per piece: 2.4 per collocation point


def unit_direction(u):
    """u / |u| (u where |u| = 0): the `control_map` of a constant-magnitude engine, which flies
    the interpolated direction renormalised to unit length."""
    norm = jnp.linalg.norm(u)
    return u / jnp.where(norm > 0.0, norm, 1.0)


def check_pieces(n: int) -> int:
    """Check pieces per segment of n collocation points (ceil(n / POINTS_PER_PIECE))."""
    return max(1, -(-n // POINTS_PER_PIECE))


def _segments(grid):
    """(breaks, points per segment) of a `Grid` (one segment [-1, 1]) or a `Mesh`."""
    if isinstance(grid, Mesh):
        return grid.breaks, grid.segment.n
    if not isinstance(grid, Grid):
        raise ValueError(f"grid must be a Grid or a Mesh, got {type(grid).__name__}")
    return jnp.array([-1.0, 1.0]), grid.n


def check_mesh(grid) -> LGRMesh:
    """The check mesh of a grid: each of its segments (one segment [-1, 1] for a `Grid`) cut
    into `check_pieces(n_k)` equal pieces of `CHECK_POINTS` Radau points each: more points
    than the segment has, in small pieces, so that the check flight's Newton systems stay
    small (12 x n_x unknowns) whatever the grid. A `PaddedGrid` of lgl(n): lgl(n)'s pieces,
    then pieces of zero length at tau = 1 up to its capacity's count."""
    if type(grid) is Grid:
        # fixed nodes: a mesh of constants (host arithmetic), so that `_interpolate` has host
        # matrices
        c = check_pieces(grid.n)
        return LGRMesh(breaks=jnp.asarray(np.linspace(-1.0, 1.0, c + 1)),
                       segment=lgr_mesh(1, CHECK_POINTS).segment)
    return _check_mesh(grid)


def _check_mesh(grid) -> LGRMesh:
    breaks, n = _segments(grid)
    c = check_pieces(n)
    fraction = jnp.arange(c) / c
    if isinstance(grid, PaddedGrid):
        # the grid's own pieces, then the padding's: zero length at the end (tau = 1), where
        # the estimate and the check flight stand still
        live = jnp.maximum(1, -(-grid.live // POINTS_PER_PIECE))
        fraction = jnp.where(jnp.arange(c) < live, jnp.arange(c) / live, 1.0)
    cuts = breaks[:-1, None] + jnp.diff(breaks)[:, None] * fraction[None]
    return LGRMesh(breaks=jnp.concatenate([cuts.reshape(-1), breaks[-1:]]),
                   segment=lgr_mesh(1, CHECK_POINTS).segment)


class Defects(NamedTuple):
    """The estimate on the check rows (per segment: its m - 1 Radau points after the start,
    then its end), in the problem's units.

    tau      (K, m) grid coordinate of the check rows
    s        (K, m) independent variable there
    errors   (K, m, n_x) Xhat - X
    states   (K, m, n_x) X, the solution's state polynomial
    relative (K,) each segment's relative error (module docstring; the largest of its pieces)
    path     (K m, n_g) path inequality values g at the check points (n_g = 0: none)
    """

    tau: jax.Array
    s: jax.Array
    errors: jax.Array
    states: jax.Array
    relative: jax.Array
    path: jax.Array


class _CheckInputs(NamedTuple):
    X: jax.Array        # (K, m, n_x) the state polynomial at the check points
    end: jax.Array      # (K, n_x) ... at each segment's end
    U: jax.Array        # (K, m, n_u) the applied control at the check points
    s: jax.Array        # (K, m) the independent variable there
    h: jax.Array        # (K,) the segments' half lengths in s
    data: object        # node data with leading axes (K, m), or None
    s0: jax.Array       # the initial s
    half: jax.Array     # (sf - s0) / 2


def _interpolate(grid, support, U, tau):
    """The state polynomial (values `support` on the grid's support) and the control
    interpolant (values U at its points) at the points tau. A `Grid` has fixed nodes (it is
    leafless, so tau is known while tracing): host interpolation matrices, applied by one
    matrix product each. The barycentric formula point by point would form the products of
    the coefficients with the values, (points x nodes x components), for every member of a
    batch: 200 us of a batched LQ law's 210 us estimate inputs at lgl(65)."""
    if type(grid) is Grid and not isinstance(tau, jax.core.Tracer):
        t = np.asarray(tau)
        return (jnp.tensordot(interpolation_matrix(grid.support, grid.support_bary, t),
                              support, 1),
                jnp.tensordot(interpolation_matrix(grid.points, grid.point_bary, t), U, 1))
    return (jax.vmap(lambda t: grid.interpolate_state(support, t))(tau),
            jax.vmap(lambda t: grid.interpolate_control(U, t))(tau))


def _check_inputs(ocp_check, check, grid, X, U, sf, control_map):
    sf = ocp_check.sf if sf is None else sf
    s0 = ocp_check.s0
    k, m, n_x = check.n_segments, check.segment.n, X.shape[-1]
    with jax.ensure_compile_time_eval():
        # constants where the check mesh's breaks are (NumPy then: `Mesh.xp`)
        tau = check.points
        rows = check.xp.concatenate([tau, check.xp.asarray(check.breaks)[1:]])
    states, Uc = _interpolate(grid, X[support_rows(grid)], U, rows)
    Uc = Uc[:tau.size]
    if control_map is not None:
        Uc = jax.vmap(control_map)(Uc)
    data = (None if ocp_check.node_data is None else jax.tree_util.tree_map(
        lambda d: d.reshape(k, m, *d.shape[1:]), ocp_check.node_data))
    return _CheckInputs(states[:tau.size].reshape(k, m, n_x), states[tau.size:],
                        Uc.reshape(k, m, -1), (s0 + 0.5 * (sf - s0) * (tau + 1.0)).reshape(k, m),
                        0.5 * (sf - s0) * 0.5 * jnp.diff(check.breaks), data, s0,
                        0.5 * (sf - s0))


def _rates(ocp, Y, s, U, data):
    """F at each point of one segment, (m, n_x)."""
    axis = None if data is None else 0
    return jax.vmap(lambda y, si, u, d: ocp.dynamics(si, y, u, d, ocp.params),
                    in_axes=(0, 0, 0, axis))(Y, s, U, data)


def collocation_defects(ocp_check, check: LGRMesh, grid, X, U, sf=None,
                        control_map=None) -> Defects:
    """The estimate of the module docstring for the solution with state rows X and controls U
    on `grid` (a `Grid` or a `Mesh`), the problem `ocp_check` built on the check mesh
    `check` (`check_mesh(grid)`, so its node data sit at the check points); sf: the final s
    (a free final s), default ocp_check.sf; control_map: applied to the interpolated control
    (e.g. its direction, for a constant-magnitude engine), None: as it is."""
    c = _check_inputs(ocp_check, check, grid, X, U, sf, control_map)
    F = jax.vmap(lambda *a: _rates(ocp_check, *a), in_axes=(0, 0, 0, 0 if c.data is not None
                                                             else None))(c.X, c.s, c.U, c.data)
    seg = check.segment
    inner = jnp.einsum("ij,kjx->kix", jnp.asarray(seg.integration)[1:], F)
    end = jnp.einsum("j,kjx->kx", jnp.asarray(seg.weights), F)
    Xhat = c.X[:, :1] + c.h[:, None, None] * jnp.concatenate([inner, end[:, None]], axis=1)
    states = jnp.concatenate([c.X[:, 1:], c.end[:, None]], axis=1)
    errors = Xhat - states
    scale = 1.0 + jnp.max(jnp.abs(states), axis=1)                          # (K, n_x)
    pieces = jnp.max(jnp.abs(errors) / scale[:, None], axis=(1, 2))
    relative = pieces.reshape(-1, check_pieces(_segments(grid)[1])).max(axis=1)
    if ocp_check.path is None:
        path = jnp.zeros((c.s.size, 0), X.dtype)
    else:
        axis = None if ocp_check.node_data is None else 0
        path = jax.vmap(ocp_check.path, in_axes=(0, 0, 0, axis, None))(
            c.s.reshape(-1), c.X.reshape(c.s.size, -1), c.U.reshape(c.s.size, -1),
            ocp_check.node_data, ocp_check.params).reshape(c.s.size, -1)
    tau = check.points.reshape(c.s.shape)
    tau_rows = jnp.concatenate([tau[:, 1:], check.breaks[1:, None]], axis=1)
    s_rows = c.s0 + c.half * (tau_rows + 1.0)
    return Defects(tau_rows, s_rows, errors, states, relative, path)


FLIGHT_NEWTON_STEPS = 4   # the polynomial is the Newton start: the flight's IVP is nearly linear


def check_flight(ocp_check, check: LGRMesh, grid, X, U, sf=None, control_map=None,
                 newton_steps: int = FLIGHT_NEWTON_STEPS):
    """The flight of the solution's control on the check mesh (module docstring): its states
    (K, m, n_x) on the check rows of `collocation_defects` (the m - 1 Radau points after each
    segment's start, then its end), in the problem's units, from the solution's initial state
    X[0] (`piecewise_flight`)."""
    c = _check_inputs(ocp_check, check, grid, X, U, sf, control_map)
    return piecewise_flight(ocp_check, check.segment, c.X, c.U, c.s, c.h, c.data,
                            newton_steps)


def piecewise_flight(ocp, segment, X, U, s, h, data=None,
                     newton_steps: int = FLIGHT_NEWTON_STEPS):
    """Fly the controls U (K, m, n_u) given at the Radau points of `segment` (lgr(m)) on K
    consecutive pieces of half lengths h (K,) in s (points s (K, m)) from X[0, 0]: per piece,
    from the flight's state at its start, Newton's method (`newton_steps`, started from the
    states X (K, m, n_x) the solution has there; 1 is exact for linear dynamics) on the m n_x
    collocation equations Y_j = Y_0 + h sum_l A_jl F(s_l, Y_l, U_l), each Newton system by
    LAPACK's LU (`lu_solve`: member by member under vmap; Gaussian elimination in array
    operations, 2 m n_x loop steps per system, had made the check flight 10 to 20 ms of every
    refined member and 6 of the STM law's 7 ms per problem in a batch), then the Radau
    quadrature to its end. Returns the flown states (K, m, n_x) at each piece's points after
    its start and at its end. data: per-point node data with leading axes (K, m), or None.
    An estimate, not differentiated: its inputs pass through `stop_gradient`."""
    ocp, X, U, s, h, data = jax.lax.stop_gradient((ocp, X, U, s, h, data))
    m, n_x = segment.n, X.shape[-1]
    A = jnp.asarray(segment.integration)
    w = jnp.asarray(segment.weights)
    eye = jnp.eye(m * n_x, dtype=X.dtype)

    def piece(y0, inputs):
        guess, s_k, U_k, d_k, h_k = inputs
        f = lambda Y: _rates(ocp, Y, s_k, U_k, d_k)                          # noqa: E731

        def newton(_, Y):
            F, J = f(Y), jax.vmap(jax.jacfwd(
                lambda y, si, u, d: ocp.dynamics(si, y, u, d, ocp.params)),
                in_axes=(0, 0, 0, None if d_k is None else 0))(Y, s_k, U_k, d_k)
            R = Y - y0 - h_k * (A @ F)
            big = eye - h_k * (A[:, :, None, None] * J[None]).transpose(0, 2, 1, 3).reshape(
                m * n_x, m * n_x)
            return Y - lu_solve(big, R.reshape(-1)).reshape(m, n_x)

        Y = jax.lax.fori_loop(0, newton_steps, newton, guess - guess[0] + y0)
        end = y0 + h_k * (w @ f(Y))
        return end, jnp.concatenate([Y[1:], end[None]])

    return jax.lax.scan(piece, X[0, 0], (X, s, U, data, h))[1]


def separable_flight(ocp_check, check: LGRMesh, grid, X, U, kernel, sf=None,
                     control_map=None):
    """`check_flight` for dynamics linear in the state, F(s, x, u) = A(s) x + b(s, u), whose
    transition matrix is a finite sum of separable terms, Phi(s, r) = sum_i P_i(s) Q_i(r) (one
    term Psi(s) Psi(r)^-1 for a fundamental matrix Psi; two for Yamanaka-Ankersen's, whose
    secular term is linear in the time). By the variation of constants, on each piece
    [b_k, b_k+1] of the check mesh,

        x(s) = sum_i P_i(s) [Q_i(b_k) x(b_k) + int_{b_k}^{s} Q_i(r) b(r, u(r)) dr],

    the integrals by the piece's Radau integration matrix and quadrature (module docstring),
    every piece at once; the pieces' starts x(b_k) then by the recurrence
    x(b_k+1) = Phi(b_k+1, b_k) x(b_k) + d_k, a loop of 6 x 6 products: no Newton system.
    b(s, u) = F(s, 0, u) is the problem's own dynamics at x = 0. kernel(s, origin) -> (P, Q)
    for arrays s and origin of one shape: lists over the terms of n_x x n_x nested-list
    matrices whose entries are arrays of that shape or Python numbers (structural zeros,
    skipped: `jaxlpm.linalg.entries_mv`), such that Phi(s, r) = sum_i P_i(s) Q_i(r) for s, r
    taken with the same origin; the flight takes each piece's start as its origin, so that a
    secular term stays small and the terms do not cancel. Returns the flown states
    (K, m, n_x) on the check rows, in the problem's units, from the solution's initial state;
    an estimate, not differentiated."""
    c = _check_inputs(ocp_check, check, grid, X, U, sf, control_map)
    ocp, c = jax.lax.stop_gradient((ocp_check, c))
    seg = check.segment
    k, m, n_x = c.X.shape
    b = jax.vmap(lambda *a: _rates(ocp, *a), in_axes=(0, 0, 0, 0 if c.data is not None
                                                       else None))(
        jnp.zeros_like(c.X), c.s, c.U, c.data)                                # (K, m, n)
    origin = jnp.broadcast_to(c.s[:, :1], (k, m))            # each piece's start, s_k0 = b_k

    def stacked(entries, shape):
        return jnp.stack([jnp.broadcast_to(x, shape) for x in entries])

    def dense(M, column):                    # (n, n, K) of a nested list's entries in a column
        return jnp.stack([stacked(row, (k,)) for row in entries_at(M, column)])

    Q = kernel(c.s, origin)[1]                                  # at the points, (K, m) entries
    b = [b[..., j] for j in range(n_x)]
    integrand = jnp.stack([stacked(entries_mv(Qi, b), (k, m)) for Qi in Q])  # (r, n, K, m)
    inner = jnp.einsum("jl,rikl->rikj", jnp.asarray(seg.integration)[1:], integrand)
    total = jnp.einsum("l,rikl->rik", jnp.asarray(seg.weights), integrand)
    forced = (jnp.concatenate([inner, total[..., None]], axis=-1)
              * c.h[:, None])                                                # (r, n, K, m)
    with jax.ensure_compile_time_eval():
        tau_rows = jnp.concatenate([check.points.reshape(k, m)[:, 1:], check.breaks[1:, None]],
                                   axis=1)
    P = kernel(c.s0 + c.half * (tau_rows + 1.0), origin)[0]      # at the rows, (K, m) entries
    # the pieces' starts (the first point, J = 0 there) and ends (the last row)
    Q0 = jnp.stack([dense(Qi, 0) for Qi in Q])                                # (r, n, n, K)
    P1 = jnp.stack([dense(Pi, -1) for Pi in P])

    def step(x, inputs):                   # x(b_k+1) = sum_i P_i(b_k+1) (Q_i(b_k) x + d_ik)
        q, p, d = inputs
        return jnp.sum(p * (jnp.sum(q * x, axis=-1) + d)[:, None], axis=(0, 2)), x

    starts = jax.lax.scan(step, c.X[0, 0], tuple(jnp.moveaxis(a, -1, 0) for a in (
        Q0, P1, forced[..., -1])))[1]                                         # (K, n)
    coefficients = jnp.sum(Q0 * starts.T[None, None], axis=2)[..., None] + forced
    terms = [entries_mv(Pi, list(a)) for Pi, a in zip(P, coefficients)]
    return jnp.moveaxis(stacked([entries_sum(row) for row in zip(*terms)], (k, m)), 0, -1)
