"""Newton-KKT (SQP) solver for a transcribed `OptimalControlProblem` with equality constraints.

Each iteration solves the Newton system of the KKT conditions of min f(z) s.t. c(z) = 0
(Nocedal & Wright 2006, Alg. 18.3, with exact second derivatives):

    [ H + dw I   A^T   ] [ p      ]     [ grad f ]
    [ A         -dc I  ] [ lambda+ ] = - [ c      ],   H = hess_z (f + lambda^T c),  A = dc/dz

H and A come from JAX autodiff, assembled from the collocation structure by
`jaxlpm.nlp.transcription` (per-point blocks: the dynamics and running cost couple only
x_i and u_i, D X is linear). How the system is solved is the `linear_algebra` class's job:
`DenseKKT` (here: one LU of the whole matrix, any transcription) or
`jaxlpm.nlp.condensed.CondensedSecondOrder` (the null-space system of the eliminated
defects, fully actuated second-order problems). Regularisation (inertia correction as in
IPOPT, Waechter & Biegler 2006 §3.1): dw = dc = 0 first; while the solve is not ok, retry with
dw = max(1e-8 scale, dw_last / 4), then 100x per retry, and dc = 1e-12. `DenseKKT` calls a solve
not ok if it is not finite, the sign of det K shows the wrong inertia (see `_kkt_step`), or
the step's null-space component p_N (p less its least-squares range-space part
A^T (A A^T)^-1 A p) has negative curvature p_N^T (H + dw I) p_N < 0.
Globalisation: the l1 merit f + mu |c|_1 (mu >= 1.5 |lambda+|_inf) with Armijo backtracking,
after trying the full step and, if the merit rejects it, its second-order correction (against
the Maratos effect; the corrected step is also accepted when it halves the KKT residual).
First multipliers from the linear algebra class (least squares for `DenseKKT`). Iterations
run in one `lax.while_loop` with a static maximum (convergence is also tested after the last
step); a solve whose KKT residual has not fallen below 0.9 of its best over the last
`stall_iterations` iterations ends STALLED (stuck: tiny steps along a nearly singular Newton
step). The result carries a `Status`, residuals, the residual history and the multipliers.
Optionally, a failed solve is retried by continuation along a homotopy of the problem
(`newton_kkt`'s homotopy argument). Solutions are differentiated by the
implicit function theorem on the KKT conditions (`jaxlpm.implicit.root`), never through the
iterations.
"""

import functools
from dataclasses import dataclass
from typing import NamedTuple

import jax
import jax.numpy as jnp

from .._validation import check_finite, is_concrete
from ..implicit import root
from ..linalg import cholesky_factor, cholesky_factor_solve, sequential_when_batched
from .transcription import (equality, equality_jacobian, lagrangian,
                                      lagrangian_hessian, n_variables, objective)
from ..status import Status

_RUNNING = -1


@dataclass(frozen=True)
class NewtonOptions:
    """Static solver settings (hashable: one compiled solver per distinct set).

    tol_feasibility   max |c| at convergence (problem units: the builders make states O(1))
    tol_optimality    max |grad f + A^T lambda| at convergence
    stall_iterations  a solve ends STALLED when max(|c|, |grad L|) has not fallen below 0.9
                      of its smallest value over this many iterations (0: no stall test)
    max_continuation, continuation_start   the continuation that `newton_kkt` runs when it is
                      given a homotopy and the direct solve fails
    """

    max_iterations: int = 40
    tol_feasibility: float = 1e-10
    tol_optimality: float = 1e-10
    max_backtracks: int = 30
    max_regularisations: int = 6
    armijo: float = 1e-4
    stall_iterations: int = 8
    max_continuation: int = 64       # Newton solves of the continuation after a failed start
    continuation_start: float = 1.0 / 64.0   # its first t (see `newton_kkt`'s homotopy)


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class NLPResult:
    """Outcome of `newton_kkt`.

    z            decision vector (see `jaxlpm.nlp.transcription`)
    multipliers  lambda of the equality constraints (defects, then boundary)
    status       `Status` code (int32)
    iterations   Newton iterations taken
    constraint_residual, stationarity_residual   max |c|, max |grad_z L| at z
    history      KKT residual max(|c|, |grad L|) at the start of each iteration (zeros after)
    regularisation  largest dw used
    """

    z: jax.Array
    multipliers: jax.Array
    status: jax.Array
    iterations: jax.Array
    constraint_residual: jax.Array
    stationarity_residual: jax.Array
    history: jax.Array
    regularisation: jax.Array


def kkt_residual(w, ocp, grid):
    """[grad_z L(z, lambda); c(z)] for w = [z, lambda]: zero at a KKT point."""
    n = n_variables(ocp, grid)
    z, lam = w[:n], w[n:]
    return jnp.concatenate([jax.grad(lagrangian)(z, lam, ocp, grid), equality(z, ocp, grid)])


@sequential_when_batched
def _kkt_step(H, A, g, c, dw, dc):
    """Solve the regularised Newton-KKT system by one LU factorisation; also report whether
    its inertia can be right: K symmetric with n positive and m negative eigenvalues has
    sign(det K) = (-1)^m, read off the LU factors (pivot signs and row swaps). An odd number
    of wrong eigenvalues (a reduced Hessian with one negative curvature) fails this test.
    Member by member under vmap (batched LAPACK can deadlock XLA's CPU pool,
    `jaxlpm.linalg.sequential_when_batched`); inside the Newton loop, never differentiated."""
    n, m = H.shape[0], A.shape[0]
    K = jnp.block([[H + dw * jnp.eye(n, dtype=H.dtype), A.T],
                   [A, -dc * jnp.eye(m, dtype=H.dtype)]])
    lu, piv = jax.scipy.linalg.lu_factor(K)
    sol = jax.scipy.linalg.lu_solve((lu, piv), -jnp.concatenate([g, c]))
    flips = jnp.sum(jnp.diagonal(lu) < 0) + jnp.sum(piv != jnp.arange(n + m))
    inertia_ok = (flips % 2) == (m % 2)
    return sol[:n], sol[n:], inertia_ok


def least_squares_multipliers(J, g):
    """argmin_y |g + J^T y| for the constraint Jacobian J (m, n) and the objective's gradient
    g (n,) (the normal equations through `_gram_factor`)."""
    return -cholesky_factor_solve(_gram_factor(J), J @ g)


def _least_squares_multipliers(z, ocp, grid):
    """lambda0 = argmin |grad f + A^T lambda|: the usual first multiplier estimate (IPOPT's
    default; Nocedal & Wright eq. 18.21), so the first Hessian sees the constraints' curvature."""
    return least_squares_multipliers(equality_jacobian(z, ocp, grid),
                                     jax.grad(objective)(z, ocp, grid))


def _gram_factor(A):
    """Cholesky factor of A A^T + eps I, eps = 1e-14 max diag(A A^T): exact to round-off when A
    has full row rank; finite when the constraints are redundant but consistent (a thrust
    axis removed: the defects and boundary conditions of an unactuated axis overlap), where
    it gives the least-norm solutions of the compatible systems it is used for."""
    AAt = A @ A.T
    eps = 1e-14 * jnp.max(jnp.diagonal(AAt))
    return cholesky_factor(AAt + eps * jnp.eye(A.shape[0], dtype=A.dtype))


class DenseKKT:
    """Newton-KKT linear algebra for any transcription: the whole KKT matrix by one LU per
    solve (`_kkt_step`), the step's null-space component and the second-order correction
    through the Cholesky factor of A A^T, first multipliers by least squares."""

    def __init__(self, ocp, grid, z_ref=None):       # z_ref: unused (see the condensed class)
        self.ocp, self.grid = ocp, grid

    def prepare(self, z, lam):
        A = equality_jacobian(z, self.ocp, self.grid)
        return A, _gram_factor(A)

    def hessian(self, prep, z, lam):
        return lagrangian_hessian(z, lam, self.ocp, self.grid)

    def hessian_scale(self, H):
        return jnp.max(jnp.abs(jnp.diag(H)))

    def solve(self, prep, H, g, c, dw, dc):
        """(p, lambda+, ok) of the system regularised by (dw, dc); ok: finite, inertia sign
        right and no negative curvature along p's null-space component (a range-space
        component may legitimately have p^T H p < 0 while c != 0)."""
        A, AAt = prep
        p, lam_new, inertia_ok = _kkt_step(H, A, g, c, dw, dc)
        p_n = p - A.T @ cholesky_factor_solve(AAt, A @ p)
        curvature = p_n @ (H @ p_n) + dw * (p_n @ p_n)
        finite = jnp.all(jnp.isfinite(p)) & jnp.all(jnp.isfinite(lam_new))
        return p, lam_new, finite & inertia_ok & (curvature >= 0.0)

    def correction(self, prep, r):
        """The least-norm d with A d = -r."""
        A, AAt = prep
        return -A.T @ cholesky_factor_solve(AAt, r)

    def first_multipliers(self, z):
        return _least_squares_multipliers(z, self.ocp, self.grid)


def first_multipliers(ocp, grid, z0, linear_algebra=DenseKKT):
    """The linear algebra's first estimate of the equality multipliers at z0 (`DenseKKT`:
    least squares): a starting point, not differentiated."""
    fixed_ocp, fixed_z0 = jax.lax.stop_gradient((ocp, z0))
    return linear_algebra(fixed_ocp, grid, fixed_z0).first_multipliers(fixed_z0)


def newton_step(ocp, grid, z, linear_algebra=DenseKKT):
    """One full Newton-KKT step from z with zero multipliers: the exact solution when the
    problem is a QP (linear dynamics, quadratic cost), e.g. the linear transfer's KKT law.
    linear_algebra: as in `newton_kkt`. Returns (z + p, multipliers). Not differentiable
    (its factorisations run member by member under vmap, `sequential_when_batched`): for
    initial guesses; differentiate `newton_kkt`'s solution (implicit function theorem)."""
    la = linear_algebra(ocp, grid, z)
    lam = jnp.zeros(equality(z, ocp, grid).shape, z.dtype)
    prep = la.prepare(z, lam)
    p, lam_new, _ = la.solve(prep, la.hessian(prep, z, lam), jax.grad(objective)(z, ocp, grid),
                             equality(z, ocp, grid), 0.0, 0.0)
    return z + p, lam_new


class NewtonReport(NamedTuple):
    """What a Newton loop reports beside its solution: `Status` code, iterations taken, KKT
    residual history (one entry per iteration, zeros after), the largest regularisation, and
    max |c| and max |grad_z L| at the solution returned (NaN where it is not finite)."""

    status: jax.Array
    iterations: jax.Array
    history: jax.Array
    regularisation: jax.Array
    constraint_residual: jax.Array
    stationarity_residual: jax.Array


class _RegularisedStep(NamedTuple):
    step: jax.Array
    multipliers: jax.Array
    dw: jax.Array
    ok: jax.Array
    attempt: jax.Array


class _Trial(NamedTuple):
    trial: jax.Array             # the next candidate (`line_search`)
    step: jax.Array
    alpha: jax.Array
    accepted: jax.Array
    c_full: jax.Array            # c(z + p), for the second-order correction


class _NewtonState(NamedTuple):
    z: jax.Array
    lam: jax.Array
    mu: jax.Array                # l1 merit penalty
    k: jax.Array                 # iteration
    history: jax.Array
    regularisation: jax.Array    # largest dw so far
    dw_last: jax.Array
    residuals: jax.Array         # (max |c|, max |grad L|) at the last point checked
    status: jax.Array            # _RUNNING until done


def newton_iterations(w0, ocp, grid, options: NewtonOptions, linear_algebra=DenseKKT):
    """The Newton-KKT iteration from w0 = [z0, lambda0] (see the module docstring): returns
    (w, `NewtonReport`). Not differentiable by itself (`newton_kkt` wraps it in the implicit
    function theorem); the augmented Lagrangian runs it as its inner loop."""
    n = n_variables(ocp, grid)
    z0, lam0 = w0[:n], w0[n:]
    f = functools.partial(objective, ocp=ocp, grid=grid)
    c_fun = functools.partial(equality, ocp=ocp, grid=grid)
    opts = options
    la = linear_algebra(ocp, grid, z0)

    def merit(z, mu):
        """(f(z) + mu |c(z)|_1, c(z))."""
        c = c_fun(z)
        return f(z) + mu * jnp.sum(jnp.abs(c)), c

    def residuals(z, lam):
        f0, g = jax.value_and_grad(f)(z)
        c, c_vjp = jax.vjp(c_fun, z)
        gl = g + c_vjp(lam)[0]
        return f0, g, c, jnp.max(jnp.abs(c)), jnp.max(jnp.abs(gl))

    def regularised_step(prep, H, g, c, dw_last):
        """dw = 0 first; while the backend's solve is not ok (non-finite, wrong inertia,
        negative curvature), retry with dw = max(1e-8 scale, dw_last / 4), then x100
        (IPOPT-like), and dc = 1e-12."""
        scale = 1.0 + la.hessian_scale(H)

        def cond(s):
            return (s.attempt == 0) | (~s.ok & (s.attempt <= opts.max_regularisations))

        def body(s):
            k = s.attempt
            first = jnp.maximum(1e-8 * scale, 0.25 * dw_last)
            dw = jnp.where(k == 0, 0.0, jnp.where(k == 1, first, 100.0 * s.dw))
            p, lam_new, ok = la.solve(prep, H, g, c, dw, jnp.where(k == 0, 0.0, 1e-12))
            return _RegularisedStep(p, lam_new, dw, ok, k + 1)

        nan = jnp.full(g.shape, jnp.nan, g.dtype)
        s = jax.lax.while_loop(
            cond, body, _RegularisedStep(nan, jnp.full(c.shape, jnp.nan, c.dtype),
                                         jnp.zeros((), g.dtype), jnp.array(False), 0))
        return s.step, s.multipliers, s.dw, s.ok

    def line_search(z, lam, f0, g, c, kkt, prep, p, mu):
        """(step, alpha, accepted): the full step if the merit accepts it or it halves the
        KKT residual (a condensed step meets its linearised constraints only to ~1e-12, so near
        a solution the merit's l1 term can reject it while it brings the stationarity down
        by three decades), else its second-order correction (Nocedal & Wright Alg. 18.3 /
        §15.5: p_soc = p + d with A d = -c(z + p) removes the constraints' curvature that makes
        the merit reject good Newton steps near a solution, the Maratos effect), also taken
        when it halves the KKT residual, else Armijo backtracking along p. The candidates are
        tried in turn by one loop (trial j: 0 the full step, 1 its correction, j >= 2 the
        step 2^(1-j) p), so that the program holds one merit and one KKT residual
        evaluation (issue 21: a smaller program compiles sooner)."""
        phi0 = f0 + mu * jnp.sum(jnp.abs(c))
        slope = g @ p - mu * jnp.sum(jnp.abs(c))

        def kkt_halved(step):
            w = jnp.concatenate([z + step, lam])
            return jnp.max(jnp.abs(kkt_residual(w, ocp, grid))) <= 0.5 * kkt

        def cond(t):
            return ~t.accepted & (t.trial <= opts.max_backtracks + 1)

        def body(t):
            j = t.trial
            alpha = jnp.where(j <= 1, 1.0, 0.5 ** (j - 1).astype(z.dtype))
            # the correction from c(z + p), which trial 0 left in t.c_full
            step = jax.lax.cond(j == 1, lambda: p + la.correction(prep, t.c_full),
                                lambda: alpha * p)
            phi, c_trial = merit(z + step, mu)
            sufficient = phi <= phi0 + opts.armijo * alpha * slope
            halved = jax.lax.cond((j <= 1) & ~sufficient, kkt_halved, lambda _: False, step)
            return _Trial(j + 1, step, alpha, sufficient | halved,
                          jnp.where(j == 0, c_trial, t.c_full))

        t = jax.lax.while_loop(cond, body, _Trial(0, jnp.zeros_like(p), jnp.zeros((), z.dtype),
                                                  jnp.array(False), jnp.zeros_like(c)))
        return t.step, t.alpha, t.accepted

    def newton_iteration(z, lam, mu, f0, g, c, kkt, dw_last):
        """One regularised Newton-KKT step with its line search: (z, lambda, mu, dw, status)."""
        prep = la.prepare(z, lam)
        p, lam_new, dw, ok = regularised_step(prep, la.hessian(prep, z, lam), g, c, dw_last)
        mu = jnp.maximum(mu, 1.5 * jnp.max(jnp.abs(lam_new)) + 1e-12)
        step, alpha, accepted = jax.lax.cond(
            ok, lambda _: line_search(z, lam_new, f0, g, c, kkt, prep, p, mu),
            lambda _: (jnp.zeros_like(z), jnp.zeros((), z.dtype), jnp.array(False)), None)
        moved = ok & accepted
        z_next = jnp.where(moved, z + step, z)
        lam_next = jnp.where(moved, lam + alpha * (lam_new - lam), lam)
        finite = jnp.all(jnp.isfinite(z_next)) & jnp.all(jnp.isfinite(lam_next))
        status = jnp.select([~finite, ~ok, ~accepted],
                            [Status.NONFINITE, Status.SINGULAR, Status.STALLED], _RUNNING)
        return z_next, lam_next, mu, dw, status.astype(jnp.int32)

    def body(s):
        z, lam, mu, k, hist = s.z, s.lam, s.mu, s.k, s.history
        f0, g, c, feas, opt = residuals(z, lam)
        kkt = jnp.maximum(feas, opt)
        hist = hist.at[k].set(kkt)
        converged = (feas <= opts.tol_feasibility) & (opt <= opts.tol_optimality)
        # the iteration after the last step only checks convergence (a last step that lands
        # on the solution is SUCCESS, not MAX_ITERATIONS)
        out_of_budget = k >= opts.max_iterations
        # no progress: the residual is not below 0.9 of the best of the last stall_iterations
        stalled = jnp.array(False)
        if opts.stall_iterations > 0:
            w = opts.stall_iterations
            recent = jax.lax.dynamic_slice(
                jnp.concatenate([jnp.full(w, jnp.inf, hist.dtype), hist]), (k,), (w,))
            stalled = (k >= w) & (kkt > 0.9 * jnp.min(recent))
        done = converged | out_of_budget | stalled
        # a finished pass factors nothing (unbatched; vmap runs both branches)
        final = jnp.select([converged, out_of_budget], [Status.SUCCESS, Status.MAX_ITERATIONS],
                           Status.STALLED).astype(jnp.int32)
        z, lam, mu, dw, status = jax.lax.cond(
            done, lambda _: (z, lam, mu, jnp.zeros((), z.dtype), final),
            lambda _: newton_iteration(z, lam, mu, f0, g, c, kkt, s.dw_last), None)
        k_next = jnp.where(done, k, k + 1)
        # the loop ends at a point it checked (converged, out of budget, or a step refused:
        # z and lambda stay) or at a non-finite one
        res = jnp.where(status == Status.NONFINITE, jnp.nan, jnp.stack([feas, opt]))
        return _NewtonState(z, lam, mu, k_next, hist, jnp.maximum(s.regularisation, dw), dw,
                            res, status)

    hist0 = jnp.zeros(opts.max_iterations + 1, z0.dtype)
    zero = jnp.zeros((), z0.dtype)
    state = _NewtonState(z0, lam0, zero, 0, hist0, zero, zero, jnp.zeros(2, z0.dtype),
                         jnp.asarray(_RUNNING, jnp.int32))
    s = jax.lax.while_loop(lambda s: s.status == _RUNNING, body, state)
    return jnp.concatenate([s.z, s.lam]), NewtonReport(s.status, s.k, s.history,
                                                       s.regularisation, *s.residuals)


class _ContinuationState(NamedTuple):
    w_start: jax.Array           # starting point of the next solve (the predictor)
    t_try: jax.Array             # homotopy parameter of the next solve
    t_good: jax.Array            # last converged t, and its solution
    w_good: jax.Array
    t_prev: jax.Array            # the converged t before it, and its solution
    w_prev: jax.Array
    attempts: jax.Array
    iterations: jax.Array        # Newton iterations over all solves
    w_out: jax.Array             # the result so far: the direct attempt's, or t = 1's
    report: NewtonReport
    done: jax.Array


def continuation(loop, w0, ocp, grid, options: NewtonOptions, homotopy):
    """Solve the problem from w0 by `loop(w, ocp, grid, options) -> (w, NewtonReport)`
    (`newton_iterations`); if that fails, follow homotopy(ocp, t) from t =
    continuation_start (where w0 is nearly exact) to t = 1 (the problem): t doubles after a
    success and bisects back towards the last converged t after a failure, and each solve
    starts from the secant predictor through the last two converged solutions (w0 standing
    for t = 0) (Allgower & Georg 1990, ch. 1-2: embedding with step control, predictor-
    corrector).
    One Newton loop in the compiled program, whatever the path. Returns the converged t = 1
    solution, or the direct attempt's result and status if the continuation does not get
    there within max_continuation solves; iterations are counted over all solves."""
    one = jnp.ones((), w0.dtype)

    def body(s):
        w, report = loop(s.w_start, homotopy(ocp, s.t_try), grid, options)
        ok = report.status == Status.SUCCESS
        first = s.attempts == 0
        reached = ok & (s.t_try >= 1.0)
        keep = first | reached
        w_out = jnp.where(keep, w, s.w_out)
        report_out = jax.tree_util.tree_map(lambda a, b: jnp.where(keep, a, b), report,
                                            s.report)
        advance = ok & ~first
        t_prev = jnp.where(advance, s.t_good, jnp.where(first, 0.0, s.t_prev))
        w_prev = jnp.where(advance, s.w_good, jnp.where(first, w0, s.w_prev))
        t_good = jnp.where(advance, s.t_try, jnp.where(first, 0.0, s.t_good))
        w_good = jnp.where(advance, w, jnp.where(first, w0, s.w_good))
        t_next = jnp.where(first, options.continuation_start,
                           jnp.where(ok, jnp.minimum(2.0 * s.t_try, 1.0),
                                     0.5 * (t_good + s.t_try)))
        # secant predictor through the last two converged solutions (w0 is the t -> 0 one)
        slope = (w_good - w_prev) / jnp.where(t_good > t_prev, t_good - t_prev, 1.0)
        w_next = w_good + jnp.where(t_good > t_prev, t_next - t_good, 0.0) * slope
        done = reached | (s.attempts >= options.max_continuation) | (first & ok)
        return _ContinuationState(w_next, t_next, t_good, w_good, t_prev, w_prev,
                                  s.attempts + 1, s.iterations + report.iterations, w_out,
                                  report_out, done)

    report0 = NewtonReport(jnp.asarray(_RUNNING, jnp.int32), jnp.zeros((), jnp.int32),
                           jnp.zeros(options.max_iterations + 1, w0.dtype),
                           *jnp.zeros((3,), w0.dtype))
    zero = 0.0 * one
    state = _ContinuationState(w0, one, zero, w0, zero, w0, 0, jnp.zeros((), jnp.int32), w0,
                               report0, jnp.array(False))
    s = jax.lax.while_loop(lambda s: ~s.done, body, state)
    return s.w_out, s.report._replace(iterations=s.iterations)


@functools.lru_cache(maxsize=None)
def _solver(options: NewtonOptions, homotopy=None, linear_algebra=DenseKKT):
    loop = functools.partial(newton_iterations, linear_algebra=linear_algebra)

    @root(kkt_residual, has_aux=True, zero_nonfinite=True)
    def solve(w0, ocp, grid):
        if homotopy is None:
            return loop(w0, ocp, grid, options)
        return continuation(loop, w0, ocp, grid, options, homotopy)
    return solve


def newton_kkt(ocp, grid, z0, multipliers0=None, options: NewtonOptions = NewtonOptions(),
               homotopy=None, linear_algebra=DenseKKT):
    """Solve the transcribed problem from the initial guess z0 (and multipliers).

    linear_algebra: how each Newton-KKT system is solved: `DenseKKT` (default, any
    transcription) or a structured class with the same methods, e.g.
    `jaxlpm.nlp.condensed.CondensedSecondOrder` (fully actuated second-order problems): the same
    steps, iterates and statuses, up to round-off.

    homotopy: optional `(ocp, t) -> ocp`, a module-level function (it keys the compiled
    solver) embedding the problem in a family with t = 1 the problem itself and t -> 0 one
    that z0 solves nearly exactly; when the direct solve fails, Newton follows the family
    from t = options.continuation_start to 1 (`continuation`).
    Returns an `NLPResult`; z and the multipliers are differentiable with respect to the
    problem's array leaves (params, node_data, s0, sf) by the implicit function theorem.
    Path constraints are not handled here (the augmented-Lagrangian solver does them).
    """
    if ocp.has_path_constraints and ocp.penalty is None:
        raise ValueError("newton_kkt handles equality constraints only; this problem has path "
                         "constraints or final-s bounds (use augmented_lagrangian)")
    ocp.validate()
    n = n_variables(ocp, grid)
    m = jax.eval_shape(lambda: equality(jnp.zeros(n), ocp, grid)).shape[0]
    if z0.shape != (n,):
        raise ValueError(f"z0 must have shape ({n},) for this problem and grid, got {z0.shape}")
    if multipliers0 is not None and multipliers0.shape != (m,):
        raise ValueError(f"multipliers0 must have shape ({m},) (one per equality constraint), "
                         f"got {multipliers0.shape}")
    if is_concrete(z0):
        check_finite("z0", z0)
    if multipliers0 is None:
        multipliers0 = first_multipliers(ocp, grid, z0, linear_algebra)
    w, report = _solver(options, homotopy, linear_algebra)(
        jnp.concatenate([z0, multipliers0]), ocp, grid)
    return NLPResult(z=w[:n], multipliers=w[n:], status=report.status,
                     iterations=report.iterations,
                     constraint_residual=report.constraint_residual,
                     stationarity_residual=report.stationarity_residual,
                     history=report.history, regularisation=report.regularisation)
