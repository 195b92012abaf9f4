"""The two linear-quadratic laws of Mei, Ma & Yang (2010) on LGL nodes, in 3D.

Both solve the energy-optimal transfer of `EnergyOptimalTransfer` on the Tschauner-Hempel
model, with the chief's true anomaly f as independent variable (Mei 2010 eq. 5, 11):

    minimise  1/2 int_{f0}^{fT} |U|^2 / rho^2 df,   U = u / k^4 (m), rho = 1 + e cos f
    subject to  X' = A(f) X + B(f) U,  B = [0; I] / rho^3,  X(f0), X(fT) given (TH states).

Internally time is nondimensional (true anomaly, rad) and lengths stay in metres: the
problem is linear and homogeneous in length and the TH variables x~, x~', U are all O(|x|).
Costs are returned in SI: 1/2 int |u|^2 dt (m^2/s^3) and Mei's k^2-scaled form (m^2/s^4).

stm_law: Mei 2010 §3.1, eq. (9)-(10): the terminal state as the Yamanaka-Ankersen STM plus the
    LGL quadrature of Phi(fT, f) B U; a 4x4 (in-plane) and 2x2 (out-of-plane) Gramian.
kkt_law: Mei 2010 §3.2, eq. (12)-(16): the state equations collocated with the LGL
    differentiation matrix; the equality-constrained QP (the paper's "SEQ"). Solved exactly,
    but not by a dense LU of eq. (16): the position-rate equations give V = D Q and the
    velocity-rate equations give U as an affine function of the nodal positions Q, so the QP
    is an equality-constrained least-squares problem in the interior positions (2 boundary
    velocity constraints per axis), solved by null-space QR (no normal equations: their
    condition number would be the square of an O(N^4) one). Its solution is the solution of
    eq. (16); the multipliers gamma of eq. (16) are then recovered from its stationarity.
"""

import functools

import jax
import jax.numpy as jnp
import numpy as np

from ..collocation.padded import grid_rows, padding
from ..dynamics.stm import IP, OP, ya_entries
from ..linalg import RCOND_SINGULAR, member_by_member, qr_rcond, small_spd_solve
from ..linalg import entries_mm as _mm, entries_mv as _mv, entries_sum as _sum  # nested lists
from ..linalg import entries_at as _at_node, entries_transpose as _tr
from ..linalg import materialized as _materialized
from ..linalg import structural_zero as _zero
from ..orbits import lvlh_to_th, time_from_true_anomaly, true_anomaly_from_time
from ..status import Status
from ..problems.energy_optimal import collocation_accuracy
from ..problems.scaling import length_scale
from ..solution import Collocated, Solution
from ..solution.collocated import take_rows



# Largest constraint residual, relative to the largest TH boundary state, that a solution may
# leave: both laws solve exactly, and round-off leaves at most ~2e-10 of it (measured from
# e = 0 to 0.9, 0.01 to 20 revolutions, 5 to 129 nodes). Above it the boundary states are
# not reachable with the thrust axes given (status SINGULAR).
REACH_RTOL = 1e-6


def _setup(problem, grid):
    """Shared prelude: validity, node true anomalies and times, TH boundary states."""
    valid = problem.validity()
    prob = problem.sanitized(valid)
    o = prob.orbit
    e, k2 = o.e, o.k2
    f0 = o.f0 + 0.0 * e
    fT = true_anomaly_from_time(o, prob.duration)
    half = 0.5 * (fT - f0)
    f = f0 + (grid.points + 1.0) * half
    t = time_from_true_anomaly(o, f)
    X0 = lvlh_to_th(prob.x0, f0, e, k2)
    XT = lvlh_to_th(prob.xf, fT, e, k2)
    rho = 1.0 + e * jnp.cos(f)
    return dict(valid=valid, prob=prob, e=e, k2=k2, f0=f0, fT=fT, half=half, f=f, t=t,
                X0=X0, XT=XT, rho=rho)


def _lvlh_nodes(X_th, p_th, sf, cf, e, k2):
    """Nodal LVLH states (m, m/s) and costates dJ/dx (SI) from the TH states X_th and the
    TH costates p_th at true anomalies with sines sf and cosines cf, written out on the node
    arrays so that sin f and cos f are evaluated once (Yamanaka & Ankersen 2002 eq. 81-82):
    x = x~/rho, x_dot = k2 (rho x~' + e sin f x~). The map x~ = T x is linear and
    J_SI = 1/2 int |u|^2 dt = k2^3 * 1/2 int |U|^2 / rho^2 df (u = k2^2 U,
    dt = df / (k2 rho^2)), so dJ/dx = k2^3 T^T p = k2^3 [rho p_r - e sin f p_v, p_v / (k2 rho)].
    k2 = sqrt(mu / p^3) (1/s), the orbit's `k2`."""
    rho = (1.0 + e * cf)[:, None]
    esf = (e * sf)[:, None]
    pos, dpos = X_th[:, :3], X_th[:, 3:]
    states = jnp.concatenate([pos / rho, k2 * (rho * dpos + esf * pos)], axis=1)
    p_r, p_v = p_th[:, :3], p_th[:, 3:]
    costates = k2**3 * jnp.concatenate([rho * p_r - esf * p_v, p_v / (k2 * rho)], axis=1)
    return states, costates


def _finish(method, s, grid, X_nodes, U_nodes, costates, multipliers, con_res, stat_res, rcond,
            sf, cf, estimate=True):
    """Assemble the Solution: SI outputs, costs, status; zero everything for invalid input.
    sf, cf: sin and cos of the node true anomalies, computed once (`_materialized`).
    estimate=False leaves the error estimate out (a warm start's law, `jaxlpm.solvers.
    transfer`: a smaller program)."""
    e, k2, rho, half = s["e"], s["k2"], s["rho"], s["half"]
    u = k2**2 * U_nodes                                          # m/s^2
    cost_f = 0.5 * half * jnp.sum(grid.weights * jnp.sum(u**2, axis=1) / rho**2)
    states, node_costates = _lvlh_nodes(X_nodes, costates, sf, cf, e, k2)
    length = length_scale(s["prob"])          # the TH states and controls in transfer_ocp's units
    outputs = dict(
        node_states=states, node_controls=u, cost=cost_f / k2, node_costates=node_costates,
        stats=dict(node_f=s["f"], node_states_th=X_nodes, cost_true_anomaly=cost_f,
                   costates_th=costates, multipliers=multipliers, constraint_residual=con_res,
                   stationarity_residual=stat_res, rcond=rcond,
                   **(collocation_accuracy(s["prob"], grid, X_nodes / length,
                                           U_nodes / length) if estimate else {})))
    finite = jnp.all(jnp.array([jnp.all(jnp.isfinite(v))
                                for v in jax.tree_util.tree_leaves(outputs)]))
    valid = s["valid"]
    scale = jnp.maximum(jnp.max(jnp.abs(s["X0"])), jnp.max(jnp.abs(s["XT"])))
    unreachable = ~(con_res <= REACH_RTOL * scale)     # a removed axis the drift cannot make up
    status = jnp.where(
        ~valid, Status.INVALID_INPUT,
        jnp.where(~(rcond >= RCOND_SINGULAR) | unreachable, Status.SINGULAR,
                  jnp.where(~finite, Status.NONFINITE, Status.SUCCESS)))
    keep = valid & finite
    out = jax.tree_util.tree_map(lambda v: jnp.where(keep, v, 0.0), outputs)
    prob, t = s["prob"], s["t"]
    trajectory = Collocated(
        grid=grid, times=t, dt_dtau=half / (k2 * rho**2), node_controls=out["node_controls"],
        node_costates=out["node_costates"], state_times=t, node_states=out["node_states"],
        polynomial=out["stats"]["node_states_th"], s0=s["f0"], sf=s["fT"], orbit=prob.orbit,
        clock="true-anomaly", coordinates="tschauner-hempel")
    return Solution(problem=prob, status=status.astype(jnp.int32), cost=out["cost"],
                    duration=prob.duration + 0.0 * e, trajectory=trajectory,
                    stats=out["stats"], method=method)


def _gramian(A, C, Binv, c, Jt):
    """G = sum_i c_i Psi_i Psi_i^T, Psi_i = (A + (J_T - J_i) C) Binv_i (A = F0(f_T),
    C = F1(f_T), Binv_i = F^-1(f_i) B(f_i)): A S0 A^T + A S1 C^T + C S1 A^T + C S2 C^T from the
    moments S_p = sum_i c_i (J_T - J_i)^p Binv_i Binv_i^T (structurally zero entries skipped)."""
    k = len(Binv)
    outer = [[_sum([x * y for x, y in zip(Binv[a], Binv[b]) if not (_zero(x) or _zero(y))])
              for b in range(k)] for a in range(k)]
    S0, S1, S2 = ([[outer[a][b] if _zero(outer[a][b]) else jnp.sum(w * outer[a][b], axis=-1)
                    for b in range(k)] for a in range(k)] for w in (c, c * Jt, c * Jt * Jt))
    AS1C = _mm(_mm(A, S1), _tr(C))
    return [[p + q + r + s for p, q, r, s in zip(*rows)]
            for rows in zip(_mm(_mm(A, S0), _tr(A)), AS1C, _tr(AS1C), _mm(_mm(C, S2), _tr(C)))]


def _solve_block(Gram, d, slots):
    """-G^-1 d for the Gramian block on `slots` (Mei 2010 eq. 10: nu); (nu, rcond, relative
    stationarity residual |G nu + d| / |d|)."""
    db = d[slots]
    if all(_zero(Gram[a][b]) for a in slots for b in slots):
        # no thrust acts on this block: the free drift must reach the target by itself
        # (`_finish` checks the terminal residual), nothing to solve
        return jnp.zeros_like(db), 1.0, 0.0 * db[0]
    G = jnp.array([[Gram[a][b] for b in slots] for a in slots])
    neg_nu, rcond = small_spd_solve(G, db)
    nu = -neg_nu
    dmax = jnp.max(jnp.abs(db))
    return nu, rcond, jnp.max(jnp.abs(G @ nu + db)) / jnp.where(dmax > 0, dmax, 1.0)


def _stm_nodes(F0, F1, Finv, vel, J, X0, XT, rho, c, half, S):
    """Mei 2010 eq. (9)-(10) on the 6-state TH model, from the YA parts at the nodes.

    F0, F1, Finv: 6x6 nested lists (`ya_entries`) of (n,) node arrays; vel: the velocity slots
    where B(f) = I/rho^3 acts (removed thrust axes dropped); J: (n,) k^2 (t_i - t_0);
    c_i = (fT - f0)/2 w_i rho_i^2; S: the LGL integration matrix. The Gramian is block
    diagonal (in-plane 4x4, out-of-plane 2x2, structurally): the blocks are solved apart.
    Returns the nodal states, the controls of the existing axes and the costates as lists of
    (n,) arrays, nu (6,), the constraint and stationarity residuals and rcond.
    """
    ir = 1.0 / rho
    ir3 = ir * ir * ir
    Jt = J[-1] - J
    Binv = [[0.0 if _zero(row[m]) else row[m] * ir3 for m in vel] for row in Finv]  # F^-1 B
    A, C, Finv0 = _at_node(F0, -1), _at_node(F1, -1), _at_node(Finv, 0)
    Gram = _gramian(A, C, Binv, c, Jt)
    y0 = _mv(Finv0, list(X0))                                            # F^-1(f0) X0
    d = XT - jnp.stack([p + J[-1] * q for p, q in zip(_mv(A, y0), _mv(C, y0))])
    (nu_ip, rc_ip, st_ip), (nu_op, rc_op, st_op) = (_solve_block(Gram, d, IP),
                                                    _solve_block(Gram, d, OP))
    by_slot = dict(zip([*IP, *OP], [*nu_ip, *nu_op]))
    nu = jnp.stack([by_slot[i] for i in range(6)])
    q = [p + Jt * r for p, r in zip(_mv(_tr(A), list(nu)), _mv(_tr(C), list(nu)))]
    costates = _mv(_tr(Finv), q)                                         # Phi(fT, f_i)^T nu
    U = [-ir * costates[m] for m in vel]                                 # -rho^2 B^T costates
    BU = [_sum([b * u for b, u in zip(row, U)]) for row in Binv]          # F^-1(f_j) B_j U_j
    # F^-1(f0) Phi(f0, f_j) B_j U_j = (I - J_j F^-1(f0) F1(f0)) F^-1(f_j) B_j U_j, integrated
    g = [jnp.broadcast_to(b if _zero(h) else b - J * h, J.shape)
         for b, h in zip(BU, _mv(_mm(Finv0, _at_node(F1, 0)), BU))]
    # w_i = F^-1(f0) [X_0 + (fT - f0)/2 sum_j S_ij Phi(f0, f_j) B_j U_j], X_i = F(f_i; J_i) w_i
    w = list(jnp.stack(y0)[:, None] + half * (jnp.stack(g) @ S.T))
    X = [p + J * r for p, r in zip(_mv(F0, w), _mv(F1, w))]
    con_res = jnp.max(jnp.abs(jnp.stack([x[-1] for x in X]) - XT))
    return (X, U, costates, nu, con_res, jnp.maximum(st_ip, st_op),
            jnp.minimum(rc_ip, rc_op))


def stm_law(problem, grid) -> Solution:
    """Mei 2010 eq. (10) in 3D: U_i = rho_i^2 Psi_i^T G^-1 (X_T - Phi(fT, f0) X_0),
    Psi_i = Phi(fT, f_i) B(f_i), G = (fT - f0)/2 sum_i w_i rho_i^2 Psi_i Psi_i^T, solved for
    the in-plane (4x4 Gramian) and out-of-plane (2x2) blocks separately.

    Nodal states by variation of constants with the LGL integration matrix S:
    X(f_i) = Phi(f_i, f0) [X_0 + (fT - f0)/2 sum_j S_ij Phi(f0, f_j) B_j U_j].
    All STMs come from YA's F0, F1, F^-1 at the nodes (Phi = (F0 + J F1) F^-1), built from
    sin f_i and cos f_i alone and never stored as matrices.
    """
    s = _setup(problem, grid)
    e, k2, f, half = s["e"], s["k2"], s["f"], s["half"]
    sf, cf, t = _materialized(jnp.sin(f), jnp.cos(f), s["t"])
    rho = 1.0 + e * cf                                   # _setup's rho, from the stored cos f
    s = dict(s, rho=rho, t=t)
    J = k2 * (t - t[0])
    axes = np.asarray(problem.thrust_axes)
    vel = [3 + a for a in np.flatnonzero(axes)]          # slots of x~', y~', z~' thrust acts on
    F0, F1, Finv = ya_entries(sf, cf, e)
    X, U_act, costates, nu, con_res, stat_res, rcond = _stm_nodes(
        F0, F1, Finv, vel, J, s["X0"], s["XT"], rho, half * grid.weights * rho**2, half,
        grid.integration)
    U = [jnp.zeros_like(rho)] * 3
    for m, u in zip(vel, U_act):
        U[m - 3] = u
    return _finish("stm", s, grid, jnp.stack(X, axis=-1), jnp.stack(U, axis=-1),
                   jnp.stack(costates, axis=-1), nu, con_res, stat_res, rcond, sf, cf)


def _second_order_blocks(e, f):
    """(K_i, G) of the TH equations written as Q'' = K(f) Q + G Q' + b U per block:
    in-plane Q = (x~, y~): K = diag(3/rho, 0), G = [[0, 2], [-2, 0]]; out-of-plane Q = z~:
    K = -1, G = 0 (Mei 2010 eq. 1)."""
    rho = 1.0 + e * jnp.cos(f)
    zero = jnp.zeros_like(rho)
    K_ip = jnp.stack([jnp.stack([3.0 / rho, zero], -1), jnp.stack([zero, zero], -1)], -2)
    K_op = -jnp.ones((f.shape[0], 1, 1), dtype=rho.dtype)
    return (K_ip, jnp.array([[0.0, 2.0], [-2.0, 0.0]])), (K_op, jnp.zeros((1, 1)))


def _kkt_block(Dh, K, G, b, c, q0, qT, v0, vT, active, multipliers=True):
    """Collocated second-order block (Mei 2010 eq. 12-16 for one block of m axes).

    Unknowns: interior nodal positions z. V = Dh Q, U = (Dh V - K Q - G V)/b (affine in z).
    Constraints: (Dh Q)_0 = v0, (Dh Q)_N = vT, and U_c = 0 for a removed axis c.
    Cost: 1/2 sum_i c_i |U_i|^2 over the existing axes.
    Returns (Q, V, U, gamma, constraint residual, stationarity residual, rcond);
    multipliers=False: gamma and the stationarity residual zero (not computed).
    """
    n, m = K.shape[0], K.shape[1]
    eye_m, eye_n = jnp.eye(m), jnp.eye(n)
    D2 = Dh @ Dh
    # T[i, c, j, a] = dU_{i,c} / dQ_{j,a}
    T = (D2[:, None, :, None] * eye_m[None, :, None, :]
         - Dh[:, None, :, None] * G[None, :, None, :]
         - eye_n[:, None, :, None] * K[:, :, None, :])
    T = T / b[:, None, None, None]
    P = T[:, :, 1:-1, :].reshape(n, m, (n - 2) * m)                # U = P z + q
    q = T[:, :, 0, :] @ q0 + T[:, :, -1, :] @ qT                   # (n, m)

    ends = jnp.array([0, n - 1])
    Gv = (Dh[ends][:, 1:-1][:, None, :, None] * eye_m[None, :, None, :]).reshape(2 * m, -1)
    gv = (jnp.stack([v0, vT]) - Dh[ends][:, :1] * q0 - Dh[ends][:, -1:] * qT).reshape(-1)
    act = np.asarray(active)
    Gc = jnp.concatenate([Gv] + [P[:, ax, :] for ax in np.flatnonzero(~act)])
    gc = jnp.concatenate([gv] + [-q[:, ax] for ax in np.flatnonzero(~act)])

    r, n_z = Gc.shape
    if r >= n_z:
        # no freedom left for the cost (an unactuated block, or too few nodes for a
        # partially actuated one): the constraints alone fix z, in the least-squares sense;
        # `_finish` reports SINGULAR when they are not met (the target is not reachable)
        Qg, Rg = jnp.linalg.qr(Gc)
        z = jax.scipy.linalg.solve_triangular(Rg, Qg.T @ gc, lower=False)
        rcond = qr_rcond(Rg)
    else:
        # equality-constrained least squares by null-space QR
        Qg, Rg = jnp.linalg.qr(Gc.T, mode="complete")
        Rg1 = Rg[:r, :r]
        z_p = Qg[:, :r] @ jax.scipy.linalg.solve_triangular(Rg1.T, gc, lower=True)
        Z = Qg[:, r:]
        sw = jnp.sqrt(c)[:, None]
        Pa, qa = P[:, act, :], q[:, act]
        M = (sw[:, :, None] * (Pa @ Z)).reshape(-1, Z.shape[1])
        rhs = -(sw * (jnp.einsum("icj,j->ic", Pa, z_p) + qa)).reshape(-1)
        Qm, Rm = jnp.linalg.qr(M)
        y = jax.scipy.linalg.solve_triangular(Rm, Qm.T @ rhs, lower=False)
        z = z_p + Z @ y
        rcond = jnp.minimum(qr_rcond(Rg1), qr_rcond(Rm))

    Q = jnp.concatenate([q0[None], z.reshape(n - 2, m), qT[None]])
    U = jnp.where(act[None, :], jnp.einsum("icj,j->ic", P, z) + q, 0.0)   # removed axes: none
    V = (Dh @ Q).at[0].set(v0).at[-1].set(vT)
    con_res = jnp.max(jnp.abs(jnp.concatenate([
        (Dh @ Q - V).ravel(), (Dh @ V - jnp.einsum("ica,ia->ic", K, Q) - V @ G.T
                              - b[:, None] * U).ravel()])))

    if not multipliers:
        return Q, V, U, jnp.zeros((n, 2 * m), z.dtype), con_res, 0.0 * con_res, rcond

    # multipliers of eq. (16): dL/dU = 0 gives gamma_V on existing axes; the interior-velocity
    # stationarity gives gamma_Q inside; the interior-position stationarity (overdetermined,
    # consistent at the optimum) gives gamma_Q at the ends and gamma_V on removed axes.
    gV_act = jnp.where(act[None, :], c[:, None] * U / b[:, None], 0.0)
    n_free = int((~act).sum()) * n + 2 * m

    def unpack(w):
        gV = gV_act
        for k, ax in enumerate(np.flatnonzero(~act)):
            gV = gV.at[:, ax].set(w[k * n:(k + 1) * n])
        gQ_ends = w[n_free - 2 * m:].reshape(2, m)
        gQ = Dh.T @ gV - gV @ G
        gQ = gQ.at[0].set(gQ_ends[0]).at[-1].set(gQ_ends[1])
        return gQ, gV

    def position_stationarity(w):
        gQ, gV = unpack(w)
        return (Dh.T @ gQ - jnp.einsum("iac,ia->ic", K, gV))[1:-1].ravel()

    w0 = jnp.zeros(n_free, dtype=z.dtype)
    A_ls = jax.jacfwd(position_stationarity)(w0)
    w = jnp.linalg.lstsq(A_ls, -position_stationarity(w0))[0]
    gQ, gV = unpack(w)
    stat_res = jnp.max(jnp.abs(position_stationarity(w)))
    return Q, V, U, jnp.concatenate([gQ, gV], axis=1), con_res, stat_res, rcond


def kkt_law(problem, grid, estimate: bool = True, multipliers: bool = True) -> Solution:
    """Mei 2010 eq. (12)-(16) in 3D (the paper's "SEQ" law); see the module docstring.
    estimate=False: without the error estimate in `stats`; multipliers=False: without the
    multipliers of eq. (16) (zero costates): a warm start's law, a smaller program (both
    static)."""
    s = _setup(problem, grid)
    e, rho, half, f = s["e"], s["rho"], s["half"], s["f"]
    Dh = grid.D / half
    b = 1.0 / rho**3
    weights = grid.weights
    c = half * weights / rho**2
    X0, XT = s["X0"], s["XT"]
    axes = np.asarray(problem.thrust_axes)
    (K_ip, G_ip), (K_op, G_op) = _second_order_blocks(e, f)
    pad = padding(grid)
    if pad is not None:
        # a padded grid's padding rows (zero rows and columns of D) as U = Q, cost 1/2 |Q|^2:
        # their positions solve to 0, apart from the grid's own, and the QR factors of the
        # grid's own rows come first (`jaxlpm.collocation.padded`)
        b, c, weights = (jnp.where(pad, 1.0, v) for v in (b, c, weights))
        K_ip, K_op = (jnp.where(pad[:, None, None], -jnp.eye(k.shape[-1]), k)
                      for k in (K_ip, K_op))
    n = f.shape[0]
    X = jnp.zeros((n, 6), dtype=X0.dtype)
    U = jnp.zeros((n, 3), dtype=X0.dtype)
    gamma = jnp.zeros((n, 6), dtype=X0.dtype)
    con, stat, rc = [], [], []
    for pos, K, G, ax in (([0, 1], K_ip, G_ip, axes[:2]), ([2], K_op, G_op, axes[2:])):
        pos = np.array(pos)
        vel = pos + 3
        # QR, triangular solves and SVD: member by member under vmap, derivatives included
        # (a batched jaxlib LAPACK call can deadlock XLA's CPU thread pool, `member_by_member`)
        block = member_by_member(functools.partial(_kkt_block,
                                                   active=tuple(bool(a) for a in ax),
                                                   multipliers=multipliers))
        Q, V, Ub, gam, cr, sr, rcb = block(Dh, K, G, b, c, X0[pos], XT[pos], X0[vel], XT[vel])
        X = X.at[:, pos].set(Q).at[:, vel].set(V)
        U = U.at[:, pos].set(Ub)
        gamma = gamma.at[:, pos].set(gam[:, :len(pos)]).at[:, vel].set(gam[:, len(pos):])
        con.append(cr), stat.append(sr), rc.append(rcb)
    # Fahroo-Ross costate map: gamma_i = -(fT - f0)/2 w_i p(f_i) for defects written X' - AX - BU.
    costates = -gamma / (half * weights)[:, None]
    sf, cf = _materialized(jnp.sin(f), jnp.cos(f))
    return _finish("kkt", s, grid, X, U, costates, gamma, jnp.maximum(*con),
                   jnp.maximum(*stat), jnp.minimum(*rc), sf, cf, estimate)


_NODE_STATS = {"stm": ("node_f", "node_states_th", "costates_th"),
               "kkt": ("node_f", "node_states_th", "costates_th", "multipliers")}


def unpadded(solution: Solution, grid) -> Solution:
    """A law's solution on a `PaddedGrid` as the solution on its own grid lgl(n): the node
    rows gathered on the host (`Collocated.unpadded`), no program compiled per n."""
    rows = grid_rows(grid.n, solution.trajectory.grid.n)
    stats = dict(solution.stats, **{k: take_rows(solution.stats[k], rows)
                                    for k in _NODE_STATS[solution.method]})
    return solution.replace(trajectory=solution.trajectory.unpadded(grid), stats=stats)
