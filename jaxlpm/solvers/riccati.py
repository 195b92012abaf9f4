"""Continuous algebraic Riccati equation (CARE): jit-, vmap- and grad-able, on every backend.

    A^T P + P A - P G P + Q = 0,    G = B R^-1 B^T                 (Jiang et al. 2011, §3)

`care` returns the stabilising solution P (A - G P Hurwitz), the LQR gain K = R^-1 B^T P of
u = -K x minimising 1/2 int (x^T Q x + u^T R u) dt (optimal cost 1/2 x0^T P x0), its residual
and a `Status`. The equation is generic (no physics, no units); callers nondimensionalise
(`jaxlpm.solvers.lqr` scales time by 1/n for the HCW equations).

Method. Jiang 2011 (after Laub 1979) takes P from the ordered real Schur form of the
Hamiltonian H = [[A, -G], [-Q, -A^T]]. JAX has no ordered Schur decomposition on every backend,
so the stable invariant subspace of H is found from the matrix sign function instead (Roberts
1971; Byers 1987; Gardiner & Laub 1986), which needs only LU and QR factorisations:
  1. balance P = alpha P~, alpha = sqrt(|Q|_F / |G|_F) (`balancing`): the blocks -alpha G and
     -Q / alpha of the balanced Hamiltonian have equal norms (the relative residual is
     unchanged by this);
  2. Newton's iteration for sign(H) with determinant scaling,
     Z <- (c Z + Z^-1 / c) / 2,  c = |det Z|^(-1/2n), in a lax.while_loop (static maximum),
     with the Hamiltonian structure (J Z symmetric) restored at every step;
  3. the stable subspace [I; P] of H is the null space of sign(H) + I: P solves
     [W12; W22 + I] P = -[W11 + I; W21] (consistent, overdetermined; least squares by QR);
  4. one Newton (Kleinman) step on the Riccati residual polishes P: the Lyapunov equation
     (A - G P)^T X + X (A - G P) = -F(P) is solved densely in its Kronecker form restricted to
     symmetric X (n(n+1)/2 unknowns: cheap for the n = 6 of relative motion, O(n^6) in
     general); the same operator certifies that the closed loop is stable (a Lyapunov
     solution, see `_stabilising_solution`).

A stabilising solution exists iff (A, B) is stabilisable and (Q, A) has no unobservable mode
on the imaginary axis (then H has no imaginary eigenvalues). When the solve fails, two more
solves say why (run only when a problem, or a member of a batch, failed): (A, B) is
stabilisable iff CARE(A, B, I, R) has a stabilising solution, and (Q, A) is detectable iff the
dual CARE(A^T, Q, I) (G and Q swapped) has one. If (Q, A) has an unobservable mode in the open
right half-plane the stabilising solution still exists and is returned (as scipy does); it is
then the cheapest *stabilising* law, not the cheapest law.

Derivatives: P is differentiated implicitly through F(P; A, B, Q, R) = 0 (`jaxlpm.implicit.root`):
dF/dP is the Lyapunov operator of the closed loop, invertible because A - G P is Hurwitz.
"""

from dataclasses import dataclass, replace

import jax
import jax.numpy as jnp
import numpy as np

from ..compilation import compiled
from .._validation import Checked, Rule, array_module, real_array, require_x64
from ..implicit import root
from ..linalg import RCOND_SINGULAR, member_by_member, qr_rcond, sequential_when_batched
from ..problems.lqr import weight_rules
from ..status import Status

MAX_ITERATIONS = 50     # determinant-scaled sign iterations take ~10 on the HCW cases
SIGN_TOL = 1e-8         # relative change |Z+ - Z|_1 / |Z+|_1: quadratic convergence puts the
                        # next iterate near rounding level, and the Newton step squares the rest
STAGNATION = 1e-6       # below this change a non-decreasing change is rounding noise: stop
SUBSPACE_TOL = 1e-8     # largest relative inconsistency of the subspace equations (step 3)
RESIDUAL_TOL = 1e-8     # largest relative CARE residual called SUCCESS
STABILITY_TOL = 1e-12   # smallest closed-loop stability margin, relative (see the certificate)


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class CareSolution:
    """Stabilising solution of A^T P + P A - P B R^-1 B^T P + Q = 0 and its health.

    P          (n, n) symmetric stabilising solution (0 unless status is SUCCESS)
    K          (m, n) LQR gain R^-1 B^T P: u = -K x
    residual   |A^T P + P A - P G P + Q|_F / |Q|_F of P (|.|_F alone if Q = 0), in the
               scaling the equation was given in (0 unless status is SUCCESS)
    iterations sign-function iterations (int32)
    rcond      reciprocal condition estimate of the subspace least-squares solve (step 3)
    status     `Status` code (int32): SUCCESS, INVALID_INPUT (traced bad input),
               NOT_STABILISABLE, NOT_DETECTABLE, MAX_ITERATIONS or SINGULAR (a numerical
               failure of a problem that has a stabilising solution)
    """

    P: jax.Array
    K: jax.Array
    residual: jax.Array
    iterations: jax.Array
    rcond: jax.Array
    status: jax.Array

    @property
    def message(self) -> str:
        """The status in words (concrete, unbatched solutions)."""
        return Status(int(self.status)).message


@member_by_member
def _input_gain(B, R):
    """R^-1 B^T (m, n), by a Cholesky solve (R is symmetric positive definite); member by
    member under vmap, like every LAPACK call of the CARE (batched LAPACK can deadlock XLA's
    CPU pool, `jaxlpm.linalg.sequential_when_batched`)."""
    return jax.scipy.linalg.cho_solve(jax.scipy.linalg.cho_factor(R), B.T)


def _residual(P, A, G, Q):
    return A.T @ P + P @ A - P @ G @ P + Q


def _relative_residual(P, A, G, Q):
    nq = jnp.linalg.norm(Q)
    return jnp.linalg.norm(_residual(P, A, G, Q)) / jnp.where(nq > 0, nq, 1.0)


def riccati_residual(P, A, B, Q, R):
    """F(P) = A^T P + P A - P B R^-1 B^T P + Q (the optimality condition differentiated)."""
    return _residual(P, A, B @ _input_gain(B, R), Q)


def care_residual(P, A, B, Q, R):
    """Relative residual |F(P)|_F / |Q|_F (|F(P)|_F if Q = 0)."""
    return _relative_residual(P, A, B @ _input_gain(B, R), Q)


def _norm1(M):
    return jnp.max(jnp.sum(jnp.abs(M), axis=0))


def _sign_hamiltonian(H):
    """sign(H) by the determinant-scaled Newton iteration: (W, iterations, converged).

    Converged: the relative change fell below SIGN_TOL, or stopped decreasing once below
    STAGNATION (rounding level), with every entry finite.
    """
    N = H.shape[0]
    n = N // 2
    eye, zero = jnp.eye(n, dtype=H.dtype), jnp.zeros((n, n), dtype=H.dtype)
    J = jnp.block([[zero, eye], [-eye, zero]])
    identity = jnp.eye(N, dtype=H.dtype)

    def step(Z):
        lu, piv = jax.scipy.linalg.lu_factor(Z)
        c = jnp.exp(-jnp.mean(jnp.log(jnp.abs(jnp.diagonal(lu)))))   # |det Z|^(-1/N)
        c = jnp.where(jnp.isfinite(c) & (c > 0), c, 1.0)
        Zn = 0.5 * (c * Z + jax.scipy.linalg.lu_solve((lu, piv), identity) / c)
        S = J @ Zn                                    # symmetric for a Hamiltonian matrix
        return -J @ (0.5 * (S + S.T))                 # J^-1 = -J

    def stagnated(prev, change):
        return (prev <= STAGNATION) & (change >= prev)

    def going(state):
        Z, k, prev, change = state
        return ((k < MAX_ITERATIONS) & jnp.all(jnp.isfinite(Z)) & (change > SIGN_TOL)
                & ~stagnated(prev, change))

    def body(state):
        Z, k, _, change = state
        Zn = step(Z)
        return Zn, k + 1, change, _norm1(Zn - Z) / _norm1(Zn)

    inf = jnp.asarray(jnp.inf, dtype=H.dtype)
    W, k, prev, change = jax.lax.while_loop(going, body, (H, jnp.int32(0), inf, inf))
    converged = jnp.all(jnp.isfinite(W)) & ((change <= SIGN_TOL) | stagnated(prev, change))
    return W, k, converged


def _symmetric_basis(n):
    """Row-major indices of the upper triangle of an n x n matrix, and the (n^2, n(n+1)/2)
    duplication matrix D with vec_r(X) = D x for symmetric X with upper triangle x."""
    iu, ju = np.triu_indices(n)
    D = np.zeros((n * n, iu.size))
    D[iu * n + ju, np.arange(iu.size)] = 1.0
    D[ju * n + iu, np.arange(iu.size)] = 1.0
    return iu * n + ju, D


def _lyapunov_solve(Acl, C):
    """Symmetric X_k with Acl^T X_k + X_k Acl = C_k for symmetric right-hand sides C (k, n, n).

    Dense: the Kronecker form (Acl^T (x) I + I (x) Acl^T) vec_r(X) = vec_r(C) restricted to
    symmetric X, n(n+1)/2 unknowns (21 for n = 6, a 3.5 times cheaper LU than n^2 = 36).
    """
    n = Acl.shape[0]
    eye = jnp.eye(n, dtype=Acl.dtype)
    upper, D = _symmetric_basis(n)
    L = (jnp.kron(Acl.T, eye) + jnp.kron(eye, Acl.T))[upper] @ D
    x = jnp.linalg.solve(L, C.reshape(C.shape[0], -1)[:, upper].T)
    return (jnp.asarray(D) @ x).T.reshape(C.shape)


def balancing(Q, G):
    """alpha = sqrt(|Q|_F / |G|_F) (1 where either is 0): with P = alpha P~ (costates
    lambda = alpha lambda~) the blocks -alpha G and -Q / alpha of the Hamiltonian
    [[A, -G], [-Q, -A^T]] have equal norms. A choice of scaling that the answer does not
    depend on: not differentiated."""
    nq, ng = jnp.linalg.norm(Q), jnp.linalg.norm(G)
    alpha = jnp.where((nq > 0) & (ng > 0), jnp.sqrt(nq / jnp.where(ng > 0, ng, 1.0)), 1.0)
    return jax.lax.stop_gradient(alpha)


def _stabilising_solution(A, G, Q):
    """Steps 1-4 of the module docstring for (A, G, Q): returns (P, iterations, rcond, ok).

    ok: the sign iteration converged, the subspace equations are consistent and well
    conditioned, the closed loop A - G P is certified stable (below) and the relative
    residual is at most RESIDUAL_TOL. Certificate (Lyapunov): A_cl is Hurwitz iff
    A_cl^T X + X A_cl = -I has X > 0; |X|_F |A_cl|_F <= 1 / STABILITY_TOL in addition asks
    for a stability margin above rounding (|X| >= 1 / (2 |max Re lambda(A_cl)|)), so
    eigenvalues left on the imaginary axis by an uncontrollable or unobservable mode are
    not mistaken for stable ones.
    """
    n = A.shape[0]
    alpha = balancing(Q, G)
    Gt, Qt = alpha * G, Q / alpha
    W, k, converged = _sign_hamiltonian(jnp.block([[A, -Gt], [-Qt, -A.T]]))
    eye = jnp.eye(n, dtype=A.dtype)
    lhs = jnp.concatenate([W[:n, n:], W[n:, n:] + eye])
    rhs = -jnp.concatenate([W[:n, :n] + eye, W[n:, :n]])
    q, r = jnp.linalg.qr(lhs)
    Pt = jax.scipy.linalg.solve_triangular(r, q.T @ rhs, lower=False)
    rcond = qr_rcond(r)
    scale = jnp.linalg.norm(rhs)
    inconsistency = jnp.linalg.norm(lhs @ Pt - rhs) / jnp.where(scale > 0, scale, 1.0)
    finite = jnp.all(jnp.isfinite(Pt))
    Pt = jnp.where(finite, 0.5 * (Pt + Pt.T), 0.0)

    # one Newton-Kleinman step and the Lyapunov certificate share one Lyapunov operator
    Acl = A - Gt @ Pt
    step, lyap = _lyapunov_solve(Acl, jnp.stack([-_residual(Pt, A, Gt, Qt), -eye]))
    stable = (jnp.all(jnp.isfinite(jnp.linalg.cholesky(lyap)))
              & (jnp.linalg.norm(lyap) * jnp.linalg.norm(Acl) <= 1.0 / STABILITY_TOL))
    P = alpha * (Pt + step)
    ok = (converged & finite & (rcond >= RCOND_SINGULAR) & (inconsistency <= SUBSPACE_TOL)
          & stable & jnp.all(jnp.isfinite(P)) & (_relative_residual(P, A, G, Q) <= RESIDUAL_TOL))
    return jnp.where(ok, P, 0.0), k, rcond, ok


@root(riccati_residual, has_aux=True, zero_nonfinite=True)
@sequential_when_batched          # its LU, QR and Cholesky calls: never differentiated
def _solve(init, A, B, Q, R):
    """(P, aux) for the stabilising solution of a valid CARE; aux = (iterations, rcond, status).

    A failed solve is diagnosed by two more: (A, B) is stabilisable iff CARE(A, G, I) has a
    stabilising solution, (Q, A) detectable iff the dual CARE(A^T, Q, I) has one. The three
    share one compiled `_stabilising_solution` in a while_loop that makes one trip, or three
    for a failed problem (member by member under vmap, so only a failed member makes three).
    """
    del init
    n = A.shape[0]
    G = B @ _input_gain(B, R)
    G = 0.5 * (G + G.T)
    eye = jnp.eye(n, dtype=A.dtype)
    As, Gs, Qs = jnp.stack([A, A, A.T]), jnp.stack([G, G, Q]), jnp.stack([Q, eye, eye])

    def going(state):
        j, oks = state[0], state[-1]
        return (j == 0) | ((j < 3) & ~oks[0])

    def body(state):
        j, P, k, rcond, oks = state
        Pj, kj, rj, okj = _stabilising_solution(As[j], Gs[j], Qs[j])
        first = j == 0
        return (j + 1, jnp.where(first, Pj, P), jnp.where(first, kj, k),
                jnp.where(first, rj, rcond), oks.at[j].set(okj))

    init_state = (jnp.int32(0), jnp.zeros_like(A), jnp.int32(0), jnp.zeros((), A.dtype),
                  jnp.ones(3, bool))
    _, P, k, rcond, (ok, stabilisable, detectable) = jax.lax.while_loop(going, body, init_state)
    status = jnp.select(
        [ok, ~stabilisable, ~detectable, k >= MAX_ITERATIONS],
        [Status.SUCCESS, Status.NOT_STABILISABLE, Status.NOT_DETECTABLE, Status.MAX_ITERATIONS],
        Status.SINGULAR).astype(jnp.int32)
    return P, (k, jnp.where(jnp.isfinite(rcond), rcond, 0.0), status)


def _care(A, B, Q, R):
    # invalid members solve a harmless stand-in (so that neither the solve nor its implicit
    # derivative meets a NaN) and are reported and zeroed afterwards
    inputs = CareProblem(A, B, Q, R)
    valid = inputs.validity()
    safe = inputs.sanitized(valid)
    A, B, Q, R = safe.A, safe.B, 0.5 * (safe.Q + safe.Q.T), 0.5 * (safe.R + safe.R.T)
    P, (k, rcond, status) = _solve(None, A, B, Q, R)
    status = jnp.where(valid, status, Status.INVALID_INPUT).astype(jnp.int32)
    ok = status == Status.SUCCESS
    P = jnp.where(ok, P, 0.0)
    return CareSolution(P=P, K=_input_gain(B, R) @ P, residual=jnp.where(
        ok, care_residual(P, A, B, Q, R), 0.0), iterations=k, rcond=rcond, status=status)


_care_jit = compiled(_care)


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class CareProblem(Checked):
    """The data of a CARE A^T P + P A - P B R^-1 B^T P + Q = 0 and its checks, written once
    (`jaxlpm._validation.Checked`): A (n, n), B (n, m) finite; Q (n, n) symmetric positive
    semidefinite, R (m, m) symmetric positive definite (`jaxlpm.problems.lqr.weight_rules`);
    any consistent units."""

    A: jax.Array
    B: jax.Array
    Q: jax.Array
    R: jax.Array

    def rules(self):
        xp = array_module(self)
        return [Rule("A", xp.all(xp.isfinite(self.A)), "finite"),
                Rule("B", xp.all(xp.isfinite(self.B)), "finite"),
                *weight_rules(self.Q, self.R)]

    def static_rules(self) -> None:
        A, B, Q, R = (np.shape(real_array(name, getattr(self, name))) for name in "ABQR")
        if len(A) != 2 or A[0] != A[1]:
            raise ValueError(f"A must be a square (n, n) matrix, got shape {A}")
        n = A[0]
        if len(B) != 2 or B[0] != n or B[1] < 1:
            raise ValueError(f"B must have shape ({n}, m) with m >= 1, got {B}")
        m = B[1]
        if Q != (n, n):
            raise ValueError(f"Q must have shape ({n}, {n}), got {Q}")
        if R != (m, m):
            raise ValueError(f"R must have shape ({m}, {m}), got {R}")

    def harmless(self) -> "CareProblem":
        """A stable A = -I, no input, identity weights: a CARE with solution P = I / 2."""
        n, m = np.shape(self.B)
        return replace(self, A=-np.eye(n), B=np.zeros((n, m)), Q=np.eye(n), R=np.eye(m))


def care(A, B, Q, R) -> CareSolution:
    """Stabilising solution of the CARE A^T P + P A - P B R^-1 B^T P + Q = 0 and the LQR gain.

    A (n, n), B (n, m), Q (n, n) symmetric positive semidefinite, R (m, m) symmetric positive
    definite, all float64, in any consistent units (the equation has none of its own; give it
    well-scaled, e.g. nondimensional, matrices). Concrete inputs are validated (ValueError) and
    the solve is jit-compiled once per shape; under jit/vmap/grad bad inputs give status
    INVALID_INPUT and zero outputs instead. Differentiable (implicitly) in A, B, Q and R.
    """
    require_x64()
    CareProblem(A, B, Q, R).check()
    return _care_jit(*(jnp.asarray(M, jnp.float64) for M in (A, B, Q, R)))
