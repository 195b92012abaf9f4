"""Augmented-Lagrangian solver for path constraints and final-s bounds of a transcribed
`OptimalControlProblem` (Powell-Hestenes-Rockafellar; Nocedal & Wright 2006 §17.3-17.4,
Birgin & Martinez 2014 "Practical augmented Lagrangian methods", Alg. 4.1).

    min f(z)  s.t.  c(z) = 0 (defects, boundary),  G(z) <= 0,  H(z) = 0 (path),  B(sf) <= 0

The equalities c stay hard in every inner problem, solved by Newton-KKT
(`jaxlpm.nlp.newton`); the path values G, H at the collocation points and the final-s
bounds B enter its objective through the PHR terms (`PathPenalty`). Outer iteration k:

    z_k        = argmin f + PHR(G, H, B; mu, nu, rho)  s.t. c = 0   (warm-started Newton-KKT)
    mu        <- max(0, mu + rho G),   nu <- nu + rho H              (first-order update)
    rho       <- 10 rho  if the progress measure M = max(|H|, |min(-G, mu / rho)|) (mu the
                         multipliers of the subproblem; B likewise; Birgin & Martinez eq. 4.7)
                         did not fall below 1/4 of the previous one (capped at rho_max)

A subproblem stopped by the inner iteration limit is continued (warm, same mu, nu, rho) in the
next outer iteration instead of updating from an inexact point. Stops with SUCCESS when the
inner solve converged and the violation V = max(|H|, G+, B+)
and the complementarity |min(-G, mu)| are below tol_path; INFEASIBLE when rho is at its
cap, M still does not decrease and V is above 100 tol_path (a local infeasibility
certificate: the penalty cannot buy feasibility); otherwise MAX_ITERATIONS, or the inner
failure (NONFINITE). One `lax.while_loop` around the inner
Newton loop: jit- and vmap-able. The solution is differentiated by the implicit function
theorem on the full KKT system [grad L; c; H; min(-G, mu); min(-B, mu_B)] (strict
complementarity makes it smooth at the solution), never through the iterations.
"""

import dataclasses
import functools
from dataclasses import dataclass, field
from typing import NamedTuple

import jax
import jax.numpy as jnp

from .._validation import check_finite, is_concrete
from ..implicit import root
from .ocp import PathPenalty
from .transcription import equality, equality_jacobian, n_variables, objective, path_values
from ..status import Status
from .newton import (DenseKKT, NewtonOptions, first_multipliers, least_squares_multipliers,
                     newton_iterations)

_RUNNING = -1


@dataclass(frozen=True)
class ALOptions:
    """Static settings (hashable: one compiled solver per distinct set).

    tol_path     max path violation and complementarity at convergence (problem units)
    rho0, rho_growth, rho_max   penalty: first value, growth factor, cap
    decrease     the violation must fall below decrease x the previous one, else rho grows
    inner        Newton-KKT settings of the inner problems
    """

    max_outer: int = 30
    tol_path: float = 1e-9
    rho0: float = 10.0
    rho_growth: float = 10.0
    rho_max: float = 1e10
    decrease: float = 0.25
    # no stall test in the subproblems: the PHR terms' kinks (max(0, .)^2) can make Newton
    # converge only linearly for a while, and a STALLED subproblem counts as solved
    inner: NewtonOptions = field(default_factory=lambda: NewtonOptions(max_iterations=30,
                                                                       stall_iterations=0))


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class ALResult:
    """Outcome of `augmented_lagrangian`.

    z, multipliers        decision vector and equality multipliers (as `NLPResult`)
    path_multipliers      `PathPenalty` with the path multipliers mu (>= 0), nu, mu_B and the
                          final rho
    status                `Status` code (int32); inner_status: the last inner solve's
    outer_iterations, inner_iterations (total Newton iterations)
    constraint_residual   max |c|; path_residual: max path violation V
    stationarity_residual max |grad_z (f + lambda.c + mu.G + nu.H + mu_B.B)|
    complementarity       max |min(-G, mu)| (and for the bounds)
    history               V after each outer iteration (zeros after the last)
    """

    z: jax.Array
    multipliers: jax.Array
    path_multipliers: PathPenalty
    status: jax.Array
    inner_status: jax.Array
    outer_iterations: jax.Array
    inner_iterations: jax.Array
    constraint_residual: jax.Array
    path_residual: jax.Array
    stationarity_residual: jax.Array
    complementarity: jax.Array
    history: jax.Array


def _sizes(ocp, grid):
    """(n_z, n_c, shapes of G, H, B)."""
    n = n_variables(ocp, grid)
    z = jax.ShapeDtypeStruct((n,), jnp.float64)
    m = jax.eval_shape(lambda v: equality(v, ocp, grid), z).shape[0]
    G, H, B = jax.eval_shape(lambda v: path_values(v, ocp, grid), z)
    return n, m, G.shape, H.shape, B.shape


def _split(w, ocp, grid):
    """w = [z, lambda, mu (flat), nu (flat), mu_B] -> its parts."""
    n, m, sg, sh, _ = _sizes(ocp, grid)
    a = n + m
    b = a + sg[0] * sg[1]
    c = b + sh[0] * sh[1]
    return w[:n], w[n:a], w[a:b].reshape(sg), w[b:c].reshape(sh), w[c:]


def _violation(G, H, B):
    """V = max(|H|, G+, B+) (0 for no constraints)."""
    parts = [jnp.abs(H).reshape(-1), jnp.maximum(G, 0.0).reshape(-1), jnp.maximum(B, 0.0)]
    return jnp.max(jnp.concatenate(parts + [jnp.zeros(1, G.dtype)]))


def _complementarity(G, mu, B, mu_b):
    parts = [jnp.abs(jnp.minimum(-G, mu)).reshape(-1), jnp.abs(jnp.minimum(-B, mu_b))]
    return jnp.max(jnp.concatenate(parts + [jnp.zeros(1, G.dtype)]))


def full_lagrangian(z, lam, mu, nu, mu_b, ocp, grid):
    """f + lambda.c + mu.G + nu.H + mu_B.B."""
    G, H, B = path_values(z, ocp, grid)
    return (objective(z, ocp, grid) + lam @ equality(z, ocp, grid) + jnp.sum(mu * G)
            + jnp.sum(nu * H) + jnp.sum(mu_b * B))


def al_kkt_residual(w, ocp, grid):
    """[grad_z L; c; H; min(-G, mu); min(-B, mu_B)]: zero at a KKT point (NCP form of the
    complementarity conditions, Facchinei & Pang 2003)."""
    z, lam, mu, nu, mu_b = _split(w, ocp, grid)
    G, H, B = path_values(z, ocp, grid)
    grad = jax.grad(full_lagrangian)(z, lam, mu, nu, mu_b, ocp, grid)
    return jnp.concatenate([grad, equality(z, ocp, grid), H.reshape(-1),
                            jnp.minimum(-G, mu).reshape(-1), jnp.minimum(-B, mu_b)])


class ALReport(NamedTuple):
    """What the outer loop reports beside its solution."""

    status: jax.Array
    inner_status: jax.Array      # of the last inner Newton solve
    outer_iterations: jax.Array
    inner_iterations: jax.Array
    history: jax.Array           # path violation per outer iteration
    rho: jax.Array               # the final penalty parameter


class _OuterState(NamedTuple):
    wz: jax.Array                # [z, lambda] of the last inner solve
    penalty: PathPenalty         # multipliers and rho of the next subproblem
    k: jax.Array                 # outer iteration
    inner_iterations: jax.Array
    progress: jax.Array          # the last solved subproblem's progress measure
    history: jax.Array           # path violation per outer iteration
    inner_status: jax.Array
    status: jax.Array            # _RUNNING until done


def _outer_loop(w0, rho0, ocp, grid, options: ALOptions, linear_algebra=DenseKKT):
    n, m = _sizes(ocp, grid)[:2]
    z0, lam0, mu0, nu0, mub0 = _split(w0, ocp, grid)
    opts = options
    dtype = z0.dtype
    penalty0 = PathPenalty(mu0, nu0, mub0, jnp.asarray(rho0, dtype))

    def body(s):
        pen, k, v_prev, hist = s.penalty, s.k, s.progress, s.history
        w_in, inner = newton_iterations(s.wz, ocp.replace(penalty=pen), grid, opts.inner,
                                        linear_algebra)
        st_in = inner.status
        z = w_in[:n]
        G, H, B = path_values(z, ocp, grid)
        rho = pen.rho
        # a subproblem stopped by its iteration limit is continued, warm, with the same
        # multipliers and penalty (updates from a point still moving fast would mislead
        # both), unless that continuation left the path violation where it was; one whose
        # line search stalled is as solved as Newton can make it
        v = _violation(G, H, B)
        stuck = (st_in == Status.MAX_ITERATIONS) & (k > 0) & (
            v >= 0.99 * hist[jnp.maximum(k - 1, 0)])
        solved = (st_in == Status.SUCCESS) | (st_in == Status.STALLED) | stuck
        mu = jnp.where(solved, jnp.maximum(pen.inequality + rho * G, 0.0), pen.inequality)
        nu = jnp.where(solved, pen.equality + rho * H, pen.equality)
        mu_b = jnp.where(solved, jnp.maximum(pen.bounds + rho * B, 0.0), pen.bounds)
        comp = _complementarity(G, mu, B, mu_b)
        progress = jnp.maximum(
            _violation(jnp.zeros_like(G), H, jnp.zeros_like(B)),
            _complementarity(G, pen.inequality / rho, B, pen.bounds / rho))
        hist = hist.at[k].set(v)
        slow = solved & (progress > opts.decrease * v_prev)
        rho_next = jnp.where(slow, jnp.minimum(rho * opts.rho_growth, opts.rho_max), rho)
        finite = jnp.all(jnp.isfinite(w_in)) & jnp.isfinite(v)
        converged = (st_in == Status.SUCCESS) & (v <= opts.tol_path) & (comp <= opts.tol_path)
        infeasible = (rho >= opts.rho_max) & slow & (v > 100.0 * opts.tol_path)
        status = jnp.select(
            [converged, ~finite, infeasible, k + 1 >= opts.max_outer],
            [Status.SUCCESS, Status.NONFINITE, Status.INFEASIBLE, Status.MAX_ITERATIONS],
            _RUNNING).astype(jnp.int32)
        pen_next = PathPenalty(mu, nu, mu_b, rho_next)
        w_next = jnp.where(finite, w_in, s.wz)
        return _OuterState(w_next, pen_next, k + 1, s.inner_iterations + inner.iterations,
                           jnp.where(solved, progress, v_prev), hist,
                           st_in.astype(jnp.int32), status)

    hist0 = jnp.zeros(opts.max_outer, dtype)
    state = _OuterState(jnp.concatenate([z0, lam0]), penalty0, 0, 0,
                        jnp.asarray(jnp.inf, dtype), hist0, jnp.asarray(_RUNNING, jnp.int32),
                        jnp.asarray(_RUNNING, jnp.int32))
    s = jax.lax.while_loop(lambda s: s.status == _RUNNING, body, state)
    pen = s.penalty
    w = jnp.concatenate([s.wz, pen.inequality.reshape(-1), pen.equality.reshape(-1),
                         pen.bounds])
    return w, ALReport(s.status, s.inner_status, s.k, s.inner_iterations, s.history, pen.rho)


@functools.lru_cache(maxsize=None)
def _solver(options: ALOptions, linear_algebra=DenseKKT):
    @root(al_kkt_residual, has_aux=True, zero_nonfinite=True)
    def solve(start, ocp, grid):
        return _outer_loop(*start, ocp, grid, options, linear_algebra)
    return solve


def start_penalty(ocp, grid, rho0, dtype) -> PathPenalty:
    """The first subproblem's `PathPenalty`: zero multipliers shaped as G, H and B, rho0."""
    _, _, sg, sh, sb = _sizes(ocp, grid)
    return PathPenalty(jnp.zeros(sg, dtype), jnp.zeros(sh, dtype), jnp.zeros(sb, dtype),
                       jnp.asarray(rho0, dtype))


def least_squares_start(ocp, grid, z, rho0) -> tuple:
    """(lambda0, penalty0): the equality multipliers and the path-equality multipliers nu
    together by least squares, argmin |grad f + A^T lambda + J_H^T nu| (the estimate of
    `jaxlpm.nlp.newton.first_multipliers` extended to h = 0), inequality and bound
    multipliers 0, rho = rho0: a start from which the first Hessian has the path equalities'
    curvature nu . h''. From nu = 0, a path equality whose value is 0 at z0 (a unit thrust
    direction |u|^2 - 1 of a guess) leaves the Lagrangian's Hessian singular across it (the
    PHR term's Hessian, rho grad h grad h^T, has rank one per point), and the first Newton
    step is then decided by round-off (tan2011's 20-node finite burn: a step of 1e7 that no
    line search accepts, for 7 of 8 seeds 1e-11 apart). Not differentiated."""
    fixed_ocp, z = jax.lax.stop_gradient((ocp, z))
    A = equality_jacobian(z, fixed_ocp, grid)
    J_h = jax.jacfwd(lambda v: path_values(v, fixed_ocp, grid)[1].reshape(-1))(z)
    y = least_squares_multipliers(jnp.concatenate([A, J_h]),
                                  jax.grad(objective)(z, fixed_ocp, grid))
    start = start_penalty(ocp, grid, rho0, z.dtype)
    return y[:A.shape[0]], dataclasses.replace(start, equality=y[A.shape[0]:].reshape(
        start.equality.shape))


def stack_kkt_point(result: ALResult):
    """w = [z, lambda, mu, nu, mu_B] of a result: the unknowns of `al_kkt_residual`."""
    pm = result.path_multipliers
    return jnp.concatenate([result.z, result.multipliers, pm.inequality.reshape(-1),
                            pm.equality.reshape(-1), pm.bounds])


def augmented_lagrangian(ocp, grid, z0, multipliers0=None,
                         options: ALOptions = ALOptions(), linear_algebra=DenseKKT,
                         penalty0=None) -> ALResult:
    """Solve the transcribed problem with its path constraints and final-s bounds from z0.

    multipliers0: equality multipliers (default: the linear algebra's first estimate, least
    squares for `DenseKKT`). penalty0: a `PathPenalty` to start from, its multipliers (shaped
    as G, H, B) and rho (default: multipliers 0, rho = options.rho0). linear_algebra: how the inner
    Newton-KKT systems are solved (see `newton_kkt`). Returns an `ALResult`, differentiable with respect to the problem's array
    leaves by the implicit function theorem at the KKT point.
    """
    ocp.validate()
    if ocp.penalty is not None:
        raise ValueError("ocp.penalty is set by the solver; pass the problem with penalty=None")
    n, m, sg, sh, sb = _sizes(ocp, grid)
    if z0.shape != (n,):
        raise ValueError(f"z0 must have shape ({n},) for this problem and grid, got {z0.shape}")
    if multipliers0 is not None and multipliers0.shape != (m,):
        raise ValueError(f"multipliers0 must have shape ({m},), got {multipliers0.shape}")
    if is_concrete(z0):
        check_finite("z0", z0)
    if ocp.final_bounds is not None and is_concrete(ocp.final_bounds):
        lo, hi = (float(b) for b in jnp.asarray(ocp.final_bounds))
        if not lo < hi:
            raise ValueError(f"final_bounds must satisfy sf_min < sf_max, got [{lo}, {hi}]")
    if multipliers0 is None:
        multipliers0 = first_multipliers(ocp, grid, z0, linear_algebra)
    if penalty0 is None:
        penalty0 = start_penalty(ocp, grid, options.rho0, z0.dtype)
    path0 = [jnp.reshape(v, -1).astype(z0.dtype)
             for v in (penalty0.inequality, penalty0.equality, penalty0.bounds)]
    if [v.size for v in path0] != [sg[0] * sg[1], sh[0] * sh[1], sb[0]]:
        raise ValueError(f"penalty0's multipliers must have the shapes {sg}, {sh}, {sb} of the "
                         f"path values G, H and the bounds B")
    w, (status, st_in, k, inner_total, hist, rho) = _solver(options, linear_algebra)(
        (jnp.concatenate([z0, multipliers0] + path0), penalty0.rho), ocp, grid)
    z, lam, mu, nu, mu_b = _split(w, ocp, grid)
    fixed = jax.lax.stop_gradient(w)
    res = al_kkt_residual(fixed, ocp, grid)
    zs, _, mus, _, mubs = _split(fixed, ocp, grid)
    G, H, B = path_values(zs, ocp, grid)
    return ALResult(
        z=z, multipliers=lam, path_multipliers=PathPenalty(mu, nu, mu_b, rho), status=status,
        inner_status=st_in, outer_iterations=k, inner_iterations=inner_total,
        constraint_residual=jnp.max(jnp.abs(res[n:n + m])),
        path_residual=_violation(G, H, B),
        stationarity_residual=jnp.max(jnp.abs(res[:n])),
        complementarity=_complementarity(G, mus, B, mubs), history=hist)
