"""Linear-quadratic regulators for continuous-thrust rendezvous on the HCW equations.

Jiang, Li, Zhang & Tan (2011), §2-3: the chaser's LVLH state x = [x, y, z, vx, vy, vz] (m, m/s;
x radial outward, y along-track, z orbit normal; the target at the origin of its circular
orbit, mean motion n) obeys x_dot = A x + B u (HCW, `hcw_matrix`), u the thrust acceleration
(m/s^2). The regulator minimises

    J = 1/2 x(T)^T S_T x(T) + 1/2 int_0^T (x^T Q x + u^T R u) dt      (SI; J* = 1/2 x0^T P(0) x0)

with Q symmetric positive semidefinite and R symmetric positive definite, in consistent units
(x^T Q x and u^T R u in one unit: Q's position block in 1/m^2, its velocity block in s^2/m^2
and R in s^4/m^2 make both dimensionless; the gain does not depend on the cost's unit).

hcw_lqr   the infinite-horizon design (T -> inf, the paper's law): u = -K x, K = R^-1 B^T P,
          P the stabilising solution of the algebraic Riccati equation (`care`).
FAMILY    `jaxlpm.solve` of an `LQRTransfer` (method "riccati"): the finite horizon with a
          terminal weight S_T, the hard terminal constraint x(T) = 0 (S_T -> inf), or the
          stationary law of `hcw_lqr` flown over the duration (S_T = P, which leaves P(t) = P).

Internal scaling (both): time by 1/n (tau = n t), velocities by n (x^ = [r, v / n], m),
controls by n^2 (u^ = u / n^2, m), and the cost by c = n^4 tr(R) / 3, so that
A^ = hcw_matrix(1), B^ = [0; I] and R^ = n^4 R / c has unit mean eigenvalue. Then
P = (c / n) S^-1 P^ S^-1 and K = n^2 K^ S^-1 with S = diag(1, 1, 1, n, n, n).

Finite horizon, exactly (no ODE error control): the Riccati differential equation
-dP/dt = A^T P + P A - P G P + Q is linear in the Hamiltonian variables, P = Y X^-1 with
d/dt [X; Y] = H [X; Y], H = [[A, -G], [-Q, -A^T]] (Radon's lemma). Over a uniform grid of
`steps` intervals of length h (the `grid` of `solve`: an int, default STEPS) the sweep steps
backward [X; Y] <- expm(-H h) [I; P_k] and re-normalises to P_{k-1} = Y X^-1 every step (the
modified Davison-Maki method, Kenney & Leipnik, IEEE TAC 30(10), 1985), which avoids the
exponential growth of one long propagation. The terminal pair is [X; Y](T) = [I; S_T], or
[0; I] for the hard constraint (P(T) = inf is never formed). Forward, the optimal state and
costate obey the same Hamiltonian system, so [x; lambda] <- expm(H h) [x_k; P_k x_k] steps the
closed loop exactly; between the nodes the solution is the same flow from the node before
(`jaxlpm.solution.HamiltonianFlow`), u = -R^-1 B^T lambda. Delta-v and cost integrals are
Gauss-Legendre sums on every step. The sweep balances the costates (lambda^ = alpha lambda~,
alpha = sqrt(|Q^|_F / |G^|_F), `balancing`, as the CARE does) so that H's blocks have equal
norms: weights far from balance (Q = I and R = I in SI: |Q^| ~ 1e12) would otherwise put
|H h| beyond the range of expm. Each step amplifies rounding by at most exp(h |eig(H)|):
keep h |eig(H)| below ~5 (the default 512 steps over 6 periods is h = 0.074 rad: closed-loop
rates up to ~60 n).

`Solution` of an `LQRTransfer` (frame LVLH, SI): cost J above (the Gauss-Legendre sum; with
terminal "infinite" the cost spent up to T plus 1/2 x(T)^T P x(T), i.e. 1/2 x0^T P x0);
states, controls and costates lambda = P(t) x(t) = dJ*/dx(t) exact at any t; `times` the
steps + 1 sweep nodes. stats: predicted_cost 1/2 x0^T P(0) x0; P0 (6, 6) P(0) and K0 (3, 6)
R^-1 B^T P(0) in SI (the stationary CARE's P and K for "infinite"); for "infinite" also
care_residual, care_iterations and care_rcond (`CareSolution`, nondimensional); the error
estimate (`flight_accuracy`: error_position m, error_velocity m/s, relative_error,
segment_error per step). Status: SUCCESS, INACCURATE (the estimate exceeds the tolerance:
too few steps for the closed loop), INVALID_INPUT (traced bad input), NONFINITE (a sweep
step met a singular X), or the CARE's failure for "infinite" (NOT_STABILISABLE,
NOT_DETECTABLE, ...); outputs are zeroed unless SUCCESS.
"""

from dataclasses import replace

import jax
import jax.numpy as jnp
import numpy as np

from ..compilation import compiled
from .._validation import check_finite, check_shape, is_concrete, require_x64
from ..collocation import lgr
from ..dynamics import hcw_matrix
from ..dynamics.linear import hcw_unit_rates
from ..nlp.accuracy import CHECK_POINTS, piecewise_flight
from ..nlp.ocp import OptimalControlProblem
from ..problems.lqr import LQRTransfer
from ..solution import HamiltonianFlow, Solution, zero_invalid
from ..solution.accuracy import accuracy_stats
from ..status import Status
from .family import FamilySolver
from .refine import first_accurate
from .riccati import CareProblem, CareSolution, balancing, care

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
    CareProblem(hcw_matrix(1.0), _input_matrix(), Q, R).validate()


def _scaled_problem(n, Q, R):
    """(valid, n, A^, B^, Q^, R^, s, c): n must be positive and tr(R) (the cost unit c)
    too; the CARE checks Q and R themselves."""
    valid = jnp.isfinite(n) & (n > 0) & (jnp.trace(R) > 0)
    n = jnp.where(valid, n, 1.0)
    return (valid, n) + _nondimensional(n, Q, jnp.where(valid, R, jnp.eye(3)))


def _si_matrices(P, K, n, s, c):
    """P and K of the nondimensional problem in SI (module docstring)."""
    return (c / n) * P / (s[:, None] * s[None, :]), n**2 * K / s[None, :]


def _to_si(sol, valid, n, s, c):
    """The nondimensional CARE solution with P and K in SI (zeros unless SUCCESS)."""
    status = jnp.where(valid, sol.status, Status.INVALID_INPUT).astype(jnp.int32)
    keep = status == Status.SUCCESS
    P, K = (jnp.where(keep, M, 0.0) for M in _si_matrices(sol.P, sol.K, n, s, c))
    return replace(sol, P=P, K=K, residual=jnp.where(keep, sol.residual, 0.0), status=status)


def _hcw_lqr(n, Q, R):
    valid, n, A, B, Qh, Rh, s, c = _scaled_problem(n, Q, R)
    return _to_si(care(A, B, Qh, Rh), valid, n, s, c)


_scaled_problem_jit, _to_si_jit = compiled(_scaled_problem), compiled(_to_si)


def hcw_lqr(n, Q, R) -> CareSolution:
    """Infinite-horizon LQR for HCW rendezvous (Jiang 2011 §3): u = -K x.

    n: chief mean motion (rad/s); Q (6, 6) state weight on LVLH [x, y, z, vx, vy, vz] (m, m/s;
    x radial, y along-track, z normal); R (3, 3) control weight on u (m/s^2), in consistent
    units. Returns a `CareSolution` with P (6, 6) and K (3, 6) in SI (K maps m, m/s to m/s^2;
    the optimal infinite-horizon cost is 1/2 x0^T P x0); residual, iterations, rcond and status
    are those of the nondimensional CARE the solver saw (module docstring). vmap over
    (n, Q, R) and differentiable. Concrete inputs are validated, and scaled by small compiled
    functions around the compiled `care` (whose one compilation per shape serves both).
    The design alone: `jaxlpm.solve(LQRTransfer(..., terminal="infinite"))` also flies it.
    """
    require_x64()
    if is_concrete(n, Q, R):
        _check_weights(n, Q, R)
        valid, n, A, B, Qh, Rh, s, c = _scaled_problem_jit(
            *(jnp.asarray(v, jnp.float64) for v in (n, Q, R)))
        return _to_si_jit(care(A, B, Qh, Rh), valid, n, s, c)
    return _hcw_lqr(n, Q, R)




def _sweep(n, Q, R, x0, duration, S_T, hard: bool, steps: int):
    """The finite-horizon sweep of the module docstring, in nondimensional variables with
    balanced costates (lambda^ = alpha lambda~, P^ = alpha P~, `balancing`). Returns (the
    `HamiltonianFlow`, cost J, P(0), K(0)), J, P and K in SI."""
    A, B, Qh, Rh, s, c = _nondimensional(n, Q, R)
    Gain = jax.scipy.linalg.cho_solve(jax.scipy.linalg.cho_factor(Rh), B.T)     # R^-1 B^T
    alpha = balancing(Qh, B @ Gain)
    Gain = alpha * Gain                                 # u^ = -Gain lambda~
    H = jnp.block([[A, -B @ Gain], [-Qh / alpha, -A.T]])
    m = A.shape[0]
    eye = jnp.eye(m, dtype=A.dtype)
    h = n * duration / steps
    back, fwd = jax.vmap(jax.scipy.linalg.expm)(H * jnp.stack([-h, h])[:, None, None])

    def riccati(XY):
        X, Y = XY[:m], XY[m:]
        P = jnp.linalg.solve(X.T, Y.T).T                 # Y X^-1
        return 0.5 * (P + P.T)

    S_hat = (n / c) * s[:, None] * S_T * s[None, :]    # S^; S~ = S^ / alpha
    XY_T = (jnp.concatenate([0.0 * eye, eye]) if hard
            else jnp.concatenate([eye, S_hat / alpha]))

    def back_step(XY, _):
        P = riccati(XY)
        return back @ jnp.concatenate([eye, P]), P

    _, Ps = jax.lax.scan(back_step, back @ XY_T, None, length=steps)
    Ps = Ps[::-1]                                       # P at tau_k = k h, k = 0 .. steps-1

    def fwd_step(x, P):
        z0 = jnp.concatenate([x, P @ x])
        return (fwd @ z0)[:m], z0

    _, Z = jax.lax.scan(fwd_step, x0 / s, Ps)           # Z[k] = [x_k; lambda~_k]
    flow = HamiltonianFlow(
        hamiltonian=H, gain=Gain, nodes=jnp.concatenate([Z, (fwd @ Z[-1])[None]]),
        duration=duration, rate=n, state_unit=s, costate_unit=alpha * (c / n) / s,
        control_unit=n**2, steps=steps)

    w, z = flow.quadrature()
    xq, uq = z[..., :m], -jnp.einsum("ij,kgj->kgi", Gain, z[..., m:])
    running = 0.5 * jnp.sum(w * (jnp.einsum("kgi,ij,kgj->kg", xq, Qh, xq)
                                 + jnp.einsum("kgi,ij,kgj->kg", uq, Rh, uq)))
    xT = flow.nodes[-1, :m]
    terminal = 0.0 if hard else 0.5 * xT @ S_hat @ xT
    P0, K0 = _si_matrices(alpha * Ps[0], Gain @ Ps[0], n, s, c)
    return flow, (c / n) * (running + terminal), P0, K0


def flight_accuracy(flow: HamiltonianFlow):
    """`jaxlpm.solution.accuracy` stats (SI, LVLH) of a sweep: its control u(t), flown on
    CHECK_POINTS Radau points per step from x0 (`piecewise_flight`: collocation of the IVP,
    exact for a control of the steps' polynomial accuracy), against its states x(t). The
    flow within a step is exact, so what this measures is what the sweep's steps lose: the
    jumps of the costate at the nodes (lambda re-set to P_k x_k), the rounding amplified by
    exp(h |eig(H)|) a step, and steps too long for the closed loop's fastest mode (the
    check pieces resolve about one radian of it per point)."""
    segment = lgr(CHECK_POINTS)
    m, h = flow.m, flow.step
    tau = jnp.asarray(segment.points)
    E = jax.vmap(jax.scipy.linalg.expm)(flow.hamiltonian * (0.5 * h * (tau + 1.0))[:, None,
                                                                                     None])
    z = jnp.einsum("gij,kj->kgi", E, flow.nodes[:-1])                     # (steps, m_c, 2m)
    X, U = z[..., :m], -jnp.einsum("ij,kgj->kgi", flow.gain, z[..., m:])
    s = h * (jnp.arange(flow.steps)[:, None] + 0.5 * (tau + 1.0))
    ocp = OptimalControlProblem(n_x=m, n_u=U.shape[-1], dynamics=hcw_unit_rates)
    flown = piecewise_flight(ocp, segment, X, U, s, jnp.full(flow.steps, 0.5 * h),
                             newton_steps=1)
    states = jnp.concatenate([X[:, 1:], flow.nodes[1:, None, :m]], axis=1)
    errors = flown - states
    relative = (jnp.max(jnp.abs(errors), axis=(1, 2))
                / (1.0 + jnp.max(jnp.abs(states), axis=(1, 2))))
    return accuracy_stats(errors * flow.state_unit, relative)


def _lqr_transfer(problem: LQRTransfer, steps: int) -> Solution:
    valid = problem.validity()
    problem = problem.sanitized(valid)
    n, Q, R, x0 = problem.orbit.mean_motion, problem.Q, problem.R, problem.x0
    if problem.terminal == "infinite":
        design = _hcw_lqr(n, Q, R)
        S_T, status = design.P, design.status
        stats = dict(care_residual=design.residual, care_iterations=design.iterations,
                     care_rcond=design.rcond)
    else:
        S_T, status, stats = problem.terminal_weight, jnp.int32(Status.SUCCESS), {}
    flow, cost, P0, K0 = _sweep(n, Q, R, x0, problem.duration, S_T,
                                problem.terminal == "hard", steps)
    if problem.terminal == "infinite":
        P0, K0 = design.P, design.K                     # P(t) = P: the stationary law
    stats |= dict(predicted_cost=0.5 * x0 @ P0 @ x0, P0=P0, K0=K0, **flight_accuracy(flow))
    finite = jnp.all(jnp.array([jnp.all(jnp.isfinite(v)) for v in
                                (flow.nodes, cost, stats["predicted_cost"], P0)]))
    status = jnp.select([~valid, status != Status.SUCCESS, ~finite],
                        [Status.INVALID_INPUT, status, Status.NONFINITE],
                        Status.SUCCESS).astype(jnp.int32)
    ok = status == Status.SUCCESS
    return Solution(problem=problem, status=status, cost=zero_invalid(ok, cost),
                    duration=problem.duration,
                    trajectory=replace(flow, hamiltonian=zero_invalid(ok, flow.hamiltonian),
                                       nodes=zero_invalid(ok, flow.nodes)),
                    stats=zero_invalid(ok, stats), method="riccati", frame="LVLH")


_compiled = compiled(_lqr_transfer, static_argnames="steps")


def check_grid(grid, method):
    if isinstance(grid, bool) or not isinstance(grid, (int, np.integer)) or grid < 1:
        raise ValueError(f"grid must be the number of uniform Riccati sweep steps (a positive "
                         f"int; default {STEPS}), got {grid!r:.60}")


def run(problem, grid, method, options) -> Solution:
    """Solve an `LQRTransfer` by the Riccati sweep over `grid` uniform steps (module
    docstring): jit-compiled once per (terminal kind, steps); vmap- and grad-able. Traced bad
    input gives status INVALID_INPUT and zeroed outputs. The solution is exact for any number
    of steps, but rounding grows by up to exp(h |eig(H)|) a step and the cost's quadrature
    needs the steps to resolve the closed loop: keep h |eig(H)| below ~5 (h = duration / steps
    times the fastest closed-loop rate; Q = I, R = I in SI over one period wants ~4096)."""
    return _compiled(problem, steps=int(grid))


REFINE_STEPS = (STEPS, 2 * STEPS, 4 * STEPS, 8 * STEPS)


def refine_steps(problem, options, judge, steps=REFINE_STEPS):
    """`solve(problem)` without a grid: the sweep on `steps` (512 up to 4096) until its error
    estimate meets the tolerance (`flight_accuracy`: the steps must resolve the closed loop's
    fastest mode); at the last, INACCURATE stays. stats gain "steps"."""
    solution, count = first_accurate(
        lambda n: judge(run(problem, n, "riccati", options)), steps)
    return solution.replace(stats=dict(solution.stats, steps=count))


FAMILY = FamilySolver(problem=LQRTransfer, methods={"riccati": None}, run=run,
                      default_grid=lambda problem: STEPS, check_grid=check_grid,
                      refine=refine_steps, refine_method="riccati")
