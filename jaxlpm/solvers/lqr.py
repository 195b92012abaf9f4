"""Linear-quadratic regulators for continuous-thrust rendezvous on the HCW equations.

Jiang, Li, Zhang & Tan (2011), §2-3: the chaser's LVLH state x = [x, y, z, vx, vy, vz] (m, m/s;
x radial outward, y along-track, z orbit normal; the target at the origin of its circular
orbit, mean motion n) obeys x_dot = A x + B u (HCW, `hcw_matrix`), u the thrust acceleration
(m/s^2). The regulator minimises

    J = 1/2 x(T)^T S_T x(T) + 1/2 int_0^T (x^T Q x + u^T R u) dt      (SI; J* = 1/2 x0^T P(0) x0)

with Q symmetric positive semidefinite and R symmetric positive definite, in consistent units
(x^T Q x and u^T R u in one unit: Q's position block in 1/m^2, its velocity block in s^2/m^2
and R in s^4/m^2 make both dimensionless; the gain does not depend on the cost's unit).

hcw_lqr            infinite horizon (T -> inf, the paper's law): u = -K x, K = R^-1 B^T P, P
                   the stabilising solution of the algebraic Riccati equation (`care`).
finite_horizon_lqr finite horizon, with a terminal weight S_T or the hard terminal constraint
                   x(T) = 0 (S_T -> inf); with S_T = P of `hcw_lqr` it flies the stationary law.

Internal scaling (both): time by 1/n (tau = n t), velocities by n (x^ = [r, v / n], m),
controls by n^2 (u^ = u / n^2, m), and the cost by c = n^4 tr(R) / 3, so that
A^ = hcw_matrix(1), B^ = [0; I] and R^ = n^4 R / c has unit mean eigenvalue. Then
P = (c / n) S^-1 P^ S^-1 and K = n^2 K^ S^-1 with S = diag(1, 1, 1, n, n, n).

Finite horizon, exactly (no ODE error control): the Riccati differential equation
-dP/dt = A^T P + P A - P G P + Q is linear in the Hamiltonian variables, P = Y X^-1 with
d/dt [X; Y] = H [X; Y], H = [[A, -G], [-Q, -A^T]] (Radon's lemma). Over a uniform grid of
`steps` intervals of length h the sweep steps backward [X; Y] <- expm(-H h) [I; P_k] and
re-normalises to P_{k-1} = Y X^-1 every step (the modified Davison-Maki method, Kenney &
Leipnik, IEEE TAC 30(10), 1985), which avoids the exponential growth of one long propagation.
The terminal pair is [X; Y](T) = [I; S_T], or [0; I] for the hard constraint (P(T) = inf is
never formed). Forward, the optimal state and costate obey the same Hamiltonian system, so
[x; lambda] <- expm(H h) [x_k; P_k x_k] steps the closed loop exactly, and u = -R^-1 B^T lambda
at any time within a step. Delta-v and cost integrals are Gauss-Legendre sums on every step.
Each step amplifies rounding by at most exp(h |eig(H)|): keep h |eig(H)| below ~5 (the default
512 steps over 6 periods is h = 0.074 rad: closed-loop rates up to ~60 n).
"""

from dataclasses import dataclass, replace

import jax
import jax.numpy as jnp
import numpy as np

from .._validation import check_finite, check_shape, is_concrete, require_x64
from ..dynamics import hcw_matrix
from ..status import Status
from .riccati import CareSolution, care, validate_weights

GAUSS_POINTS = 8          # Gauss-Legendre points per sweep step for delta-v and cost integrals
STEPS = 512               # default sweep steps over the horizon


def _input_matrix(dtype=jnp.float64):
    """B = [0; I] (6 x 3): the control is an acceleration on the three velocity rates."""
    return jnp.concatenate([jnp.zeros((3, 3), dtype), jnp.eye(3, dtype=dtype)])


def _nondimensional(n, Q, R):
    """(A^, B^, Q^, R^, s, c) of the scaling in the module docstring; x = s * x^."""
    one = jnp.ones((), dtype=Q.dtype)
    s = jnp.concatenate([jnp.ones(3, Q.dtype), jnp.full(3, n, Q.dtype)])
    c = n**4 * jnp.trace(R) / R.shape[0]
    return (hcw_matrix(one), _input_matrix(Q.dtype), s[:, None] * Q * s[None, :] / c,
            n**4 * R / c, s, c)


def _check_weights(n, Q, R):
    """ValueError for concrete bad inputs: n, Q (6, 6) PSD, R (3, 3) PD."""
    check_shape("n", n, ())
    if not float(check_finite("n", n)) > 0.0:
        raise ValueError(f"the mean motion n must be positive (rad/s), got {n}")
    check_shape("Q", Q, (6, 6))
    check_shape("R", R, (3, 3))
    validate_weights(check_finite("Q", Q), check_finite("R", R))


def _scaled_problem(n, Q, R):
    """(valid, n, A^, B^, Q^, R^, s, c): n must be positive and tr(R) (the cost unit c)
    too; the CARE checks Q and R themselves."""
    valid = jnp.isfinite(n) & (n > 0) & (jnp.trace(R) > 0)
    n = jnp.where(valid, n, 1.0)
    return (valid, n) + _nondimensional(n, Q, jnp.where(valid, R, jnp.eye(3)))


def _to_si(sol, valid, n, s, c):
    """The nondimensional CARE solution with P and K in SI (zeros unless SUCCESS)."""
    status = jnp.where(valid, sol.status, Status.INVALID_INPUT).astype(jnp.int32)
    keep = status == Status.SUCCESS
    P = jnp.where(keep, (c / n) * sol.P / (s[:, None] * s[None, :]), 0.0)
    K = jnp.where(keep, n**2 * sol.K / s[None, :], 0.0)
    return replace(sol, P=P, K=K, residual=jnp.where(keep, sol.residual, 0.0), status=status)


def _hcw_lqr(n, Q, R):
    valid, n, A, B, Qh, Rh, s, c = _scaled_problem(n, Q, R)
    return _to_si(care(A, B, Qh, Rh), valid, n, s, c)


_scaled_problem_jit, _to_si_jit = jax.jit(_scaled_problem), jax.jit(_to_si)


def hcw_lqr(n, Q, R) -> CareSolution:
    """Infinite-horizon LQR for HCW rendezvous (Jiang 2011 §3): u = -K x.

    n: chief mean motion (rad/s); Q (6, 6) state weight on LVLH [x, y, z, vx, vy, vz] (m, m/s;
    x radial, y along-track, z normal); R (3, 3) control weight on u (m/s^2), in consistent
    units. Returns a `CareSolution` with P (6, 6) and K (3, 6) in SI (K maps m, m/s to m/s^2;
    the optimal infinite-horizon cost is 1/2 x0^T P x0); residual, iterations, rcond and status
    are those of the nondimensional CARE the solver saw (module docstring). vmap over
    (n, Q, R) and differentiable. Concrete inputs are validated, and scaled by small compiled
    functions around the compiled `care` (whose one compilation per shape serves both).
    """
    require_x64()
    if is_concrete(n, Q, R):
        _check_weights(n, Q, R)
        valid, n, A, B, Qh, Rh, s, c = _scaled_problem_jit(
            *(jnp.asarray(v, jnp.float64) for v in (n, Q, R)))
        return _to_si_jit(care(A, B, Qh, Rh), valid, n, s, c)
    return _hcw_lqr(n, Q, R)


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class Flight:
    """A closed-loop LQ flight on the HCW equations (LVLH, SI).

    times         (k,) s, the requested output times
    states        (k, 6) m, m/s
    controls      (k, 3) m/s^2
    final_state   (6,) at the end of the horizon
    dv            int_0^T |u| dt, m/s
    cost          1/2 x(T)^T S_T x(T) + 1/2 int_0^T (x^T Q x + u^T R u) dt (the terminal term is
                  absent under the hard constraint), by Gauss-Legendre quadrature
    predicted_cost 1/2 x0^T P(0) x0 from the Riccati solution (equals `cost` at the optimum)
    status        `Status` (int32): SUCCESS, INVALID_INPUT or NONFINITE (e.g. a sweep step
                  met a singular X); `infinite_horizon_flight` passes on the CARE's status
    """

    times: jax.Array
    states: jax.Array
    controls: jax.Array
    final_state: jax.Array
    dv: jax.Array
    cost: jax.Array
    predicted_cost: jax.Array
    status: jax.Array


def _sweep(n, Q, R, x0, duration, ts, S_T, hard, steps):
    """The finite-horizon sweep of the module docstring, in nondimensional variables."""
    A, B, Qh, Rh, s, c = _nondimensional(n, Q, R)
    Gain = jax.scipy.linalg.cho_solve(jax.scipy.linalg.cho_factor(Rh), B.T)     # R^-1 B^T
    G = B @ Gain
    H = jnp.block([[A, -G], [-Qh, -A.T]])
    m = A.shape[0]
    eye = jnp.eye(m, dtype=A.dtype)
    h = n * duration / steps
    # every matrix exponential in one batched call (one compiled expm): a step backward and
    # forward, the Gauss-Legendre offsets within a step, the offsets of the output times
    xi, wi = np.polynomial.legendre.leggauss(GAUSS_POINTS)
    tau = n * ts
    k = jnp.clip(jnp.floor(tau / h).astype(jnp.int32), 0, steps - 1)
    thetas = jnp.concatenate([jnp.stack([-h, h]), 0.5 * h * (xi + 1.0), tau - k * h])
    E = jax.vmap(lambda th: jax.scipy.linalg.expm(H * th))(thetas)
    back, fwd, E_gauss, E_out = E[0], E[1], E[2:2 + GAUSS_POINTS], E[2 + GAUSS_POINTS:]

    def riccati(XY):
        X, Y = XY[:m], XY[m:]
        P = jnp.linalg.solve(X.T, Y.T).T                 # Y X^-1
        return 0.5 * (P + P.T)

    S_hat = (n / c) * s[:, None] * S_T * s[None, :]
    XY_T = jnp.where(hard, jnp.concatenate([0.0 * eye, eye]), jnp.concatenate([eye, S_hat]))

    def back_step(XY, _):
        P = riccati(XY)
        return back @ jnp.concatenate([eye, P]), P

    _, Ps = jax.lax.scan(back_step, back @ XY_T, None, length=steps)
    Ps = Ps[::-1]                                       # P at tau_k = k h, k = 0 .. steps-1

    def fwd_step(x, P):
        z0 = jnp.concatenate([x, P @ x])
        return (fwd @ z0)[:m], z0

    xT, Z = jax.lax.scan(fwd_step, x0 / s, Ps)          # Z[k] = [x_k; lambda_k]

    # outputs at the requested times, from the node before each
    out = jnp.einsum("kij,kj->ki", E_out, Z[k])
    xs, us = out[:, :m], -out[:, m:] @ Gain.T

    # Gauss-Legendre integrals over every step (the same offsets on every step)
    W = jnp.einsum("gij,kj->kgi", E_gauss, Z)           # (steps, points, 2m)
    xq, uq = W[..., :m], -jnp.einsum("ij,kgj->kgi", Gain, W[..., m:])
    w = 0.5 * h * jnp.asarray(wi)
    dv_hat = jnp.sum(w * jnp.linalg.norm(uq, axis=-1))
    running = 0.5 * jnp.sum(w * (jnp.einsum("kgi,ij,kgj->kg", xq, Qh, xq)
                                 + jnp.einsum("kgi,ij,kgj->kg", uq, Rh, uq)))
    terminal = jnp.where(hard, 0.0, 0.5 * xT @ S_hat @ xT)
    xh0 = x0 / s
    return dict(states=xs * s, controls=n**2 * us, final_state=xT * s, dv=n * dv_hat,
                cost=(c / n) * (running + terminal),
                predicted_cost=(c / n) * 0.5 * xh0 @ Ps[0] @ xh0)


def _flight(n, Q, R, x0, duration, ts, S_T, hard, steps):
    valid = (jnp.isfinite(n) & (n > 0) & jnp.isfinite(duration) & (duration > 0)
             & jnp.all(jnp.isfinite(x0)) & jnp.all(jnp.isfinite(ts))
             & jnp.all(jnp.isfinite(S_T)) & jnp.all(jnp.isfinite(Q)) & jnp.all(jnp.isfinite(R))
             & jnp.all(jnp.isfinite(jnp.linalg.cholesky(jnp.where(jnp.isfinite(R), R, 1.0)))))
    n = jnp.where(valid, n, 1.0)
    duration = jnp.where(valid, duration, 1.0)
    Q, R = jnp.where(valid, Q, jnp.eye(6)), jnp.where(valid, R, jnp.eye(3))
    out = _sweep(n, Q, R, jnp.where(valid, x0, 0.0), duration, jnp.where(valid, ts, 0.0),
                 jnp.where(valid, S_T, 0.0), hard, steps)
    finite = jnp.all(jnp.array([jnp.all(jnp.isfinite(v)) for v in out.values()]))
    status = jnp.select([~valid, ~finite], [Status.INVALID_INPUT, Status.NONFINITE],
                        Status.SUCCESS).astype(jnp.int32)
    out = {k: jnp.where(status == Status.SUCCESS, v, 0.0) for k, v in out.items()}
    return Flight(times=jnp.where(valid, ts, 0.0), status=status, **out)


_flight_jit = jax.jit(_flight, static_argnames="steps")


def finite_horizon_lqr(n, Q, R, x0, duration, ts, terminal_weight=None,
                       steps: int = STEPS) -> Flight:
    """Finite-horizon LQ rendezvous on HCW, solved exactly by the Riccati sweep (module
    docstring): the optimal closed loop from x0 to the target at the origin.

    n: chief mean motion (rad/s); Q (6, 6), R (3, 3) as in `hcw_lqr`; x0 (6,) LVLH state
    (m, m/s; x radial, y along-track, z normal); duration T (s); ts (k,) output times in
    [0, T] (s); terminal_weight S_T (6, 6) symmetric positive semidefinite, in the units of Q
    times seconds, or None for the hard terminal constraint x(T) = 0 (the limit S_T -> inf;
    with Q = 0 and R = I this is the energy-optimal transfer of `EnergyOptimalTransfer` with
    e = 0, xf = 0, which `solve(..., method="kkt")` discretises). `steps` (static) sets the
    sweep's grid. Traced bad input gives status INVALID_INPUT and zero outputs.
    """
    require_x64()
    hard = terminal_weight is None
    S_T = jnp.zeros((6, 6)) if hard else terminal_weight
    if is_concrete(n, Q, R, x0, duration, ts, S_T):
        _check_weights(n, Q, R)
        check_shape("x0", x0, (6,))
        check_finite("x0", x0)
        check_shape("duration", duration, ())
        T = float(check_finite("duration", duration))
        if not T > 0.0:
            raise ValueError(f"duration must be positive (s), got {T}")
        t = check_finite("ts", ts)
        if t.ndim != 1 or t.size == 0 or t.min() < 0.0 or t.max() > T * (1 + 1e-12):
            raise ValueError(f"ts must be a non-empty 1-D array of times in [0, {T}] s")
        if not hard:
            check_shape("terminal_weight", S_T, (6, 6))
            Sn = check_finite("terminal_weight", S_T)
            lam = np.linalg.eigvalsh(0.5 * (Sn + Sn.T))
            if not np.allclose(Sn, Sn.T, rtol=1e-10, atol=0) or lam.min() < -1e-12 * max(
                    abs(lam).max(), 1e-300):
                raise ValueError("terminal_weight must be symmetric positive semidefinite, "
                                 f"got eigenvalues {lam}")
        if not (isinstance(steps, int) and steps >= 1):
            raise ValueError(f"steps must be a positive int, got {steps!r}")
        args = [jnp.asarray(v, jnp.float64) for v in (n, Q, R, x0, duration, ts, S_T)]
        return _flight_jit(*args, jnp.asarray(hard), steps=steps)
    return _flight(n, Q, R, x0, duration, ts, S_T, jnp.asarray(hard), steps)


def infinite_horizon_flight(n, Q, R, x0, duration, ts, steps: int = STEPS):
    """Fly the stationary LQR law u = -K x of `hcw_lqr` for `duration` seconds (Jiang 2011):
    the finite-horizon sweep with terminal weight P (which leaves P(t) = P). Returns
    (CareSolution, Flight); `Flight.predicted_cost` is the infinite-horizon cost 1/2 x0^T P x0,
    `Flight.cost` the part spent up to T plus 1/2 x(T)^T P x(T) (the cost still to come)."""
    lqr = hcw_lqr(n, Q, R)
    flight = finite_horizon_lqr(n, Q, R, x0, duration, ts, terminal_weight=lqr.P, steps=steps)
    return lqr, replace(flight, status=jnp.where(lqr.status == Status.SUCCESS, flight.status,
                                                 lqr.status))
