"""Small dense linear algebra shared by the solvers."""

import functools
import operator

import jax
import jax.numpy as jnp

# A system is called singular below this reciprocal condition number: at 1e-13 a float64
# solve keeps fewer than 3 significant digits.
RCOND_SINGULAR = 1e-13


def small_spd_solve(a, b):
    """Solve a x = b for a small symmetric positive (semi)definite `a` (k <= ~6); (x, rcond).

    Jacobi-scaled Cholesky written out element by element (static k), so under vmap it is
    pure elementwise arithmetic with no per-problem LAPACK call. rcond is the estimate
    (min l_ii / max l_ii)^2 of the scaled matrix: invariant to the variables' units, exact for
    diagonal matrices, and 0 for a rank-deficient or non-finite matrix.
    """
    k = a.shape[-1]
    d = jnp.diagonal(a)
    ok = jnp.all(d > 0)
    s = 1.0 / jnp.sqrt(jnp.where(ok, d, 1.0))
    m = a * s[:, None] * s[None, :]
    L = [[None] * k for _ in range(k)]
    for j in range(k):
        diag = m[j, j] - sum(L[j][p] ** 2 for p in range(j))
        L[j][j] = jnp.sqrt(jnp.maximum(diag, 0.0))
        safe = jnp.where(L[j][j] > 0, L[j][j], 1.0)
        for i in range(j + 1, k):
            L[i][j] = (m[i, j] - sum(L[i][p] * L[j][p] for p in range(j))) / safe
    piv = jnp.stack([L[j][j] for j in range(k)])
    top = jnp.max(piv)
    rcond = (jnp.min(piv) / jnp.where(top > 0, top, 1.0)) ** 2
    rcond = jnp.where(ok & (top > 0) & jnp.isfinite(rcond), rcond, 0.0)
    safe_piv = jnp.where(piv > 0, piv, 1.0)
    rhs = b * s
    y = []
    for i in range(k):
        y.append((rhs[i] - sum(L[i][p] * y[p] for p in range(i))) / safe_piv[i])
    x = [None] * k
    for i in reversed(range(k)):
        x[i] = (y[i] - sum(L[p][i] * x[p] for p in range(i + 1, k))) / safe_piv[i]
    return jnp.stack(x) * s, rcond


def qr_rcond(r):
    """Reciprocal condition estimate min |r_ii| / max |r_ii| of a QR factor's triangle R
    (0 for a zero matrix)."""
    d = jnp.abs(jnp.diagonal(r))
    top = jnp.max(d)
    return jnp.where(top > 0, jnp.min(d) / jnp.where(top > 0, top, 1.0), 0.0)


def dense_solve(a, b):
    """Solve a x = b (a (k, k), b (k,) or (k, m)) by Gaussian elimination with partial pivoting
    in plain array operations (one `lax.fori_loop` over the k columns): no LAPACK call, so a
    vmapped batch of small systems cannot meet jaxlib's CPU batched-LAPACK thread-pool
    deadlock (see `jaxlpm._cpu_runtime`). For k up to ~100."""
    k = a.shape[-1]
    vec = b.ndim == 1
    m = jnp.concatenate([a, b[:, None] if vec else b], axis=1)
    rows = jnp.arange(k)

    def eliminate(j, m):
        p = jnp.argmax(jnp.where(rows >= j, jnp.abs(m[:, j]), -1.0))
        m = m.at[jnp.stack([j, p])].set(m[jnp.stack([p, j])])
        pivot = m[j, j]
        factor = jnp.where(rows > j, m[:, j] / jnp.where(pivot != 0, pivot, 1.0), 0.0)
        return m - factor[:, None] * m[j][None, :]

    m = jax.lax.fori_loop(0, k, eliminate, m)
    u, y = m[:, :k], m[:, k:]

    def back(i, x):
        j = k - 1 - i
        return x.at[j].set((y[j] - u[j] @ x) / u[j, j])

    x = jax.lax.fori_loop(0, k, back, jnp.zeros_like(y))
    return x[:, 0] if vec else x


def sequential_when_batched(fun):
    """`fun` (pytree arguments, array outputs), which under `jax.vmap` runs member by member
    (`lax.map` over the batched arguments, also under nested vmaps) instead of as one batched
    LAPACK call. jaxlib 0.10's batched CPU LAPACK kernels split a large enough batch over
    XLA's intra-op thread pool and block until it finishes (`jax::ParallelBatchMap`); two such
    calls at once on the 2-thread pool each wait for work queued behind the other: deadlock
    (gdb: `lapack_dtrsm_ffi`, `lapack_dgeqrf_ffi`, `lapack_dgesdd_ffi`; BENCHMARKS.md). A
    member has no batch to split, and batched LAPACK on CPU runs member by member anyway.
    Differentiable in forward mode only (no `jax.grad` of it unbatched): see
    `member_by_member`."""
    wrapped = jax.custom_batching.custom_vmap(fun)

    @wrapped.def_vmap
    def rule(axis_size, in_batched, *args):
        leaves, tree = jax.tree_util.tree_flatten(args)
        flags = jax.tree_util.tree_leaves(in_batched)
        batched = [x for x, b in zip(leaves, flags) if b]

        def one(xs):
            it = iter(xs)
            return wrapped(*jax.tree_util.tree_unflatten(
                tree, [next(it) if b else x for x, b in zip(leaves, flags)]))

        out = jax.lax.map(one, batched)
        return out, jax.tree_util.tree_map(lambda _: True, out)

    return wrapped


def member_by_member(fun, sequential=None):
    """`sequential_when_batched(fun)` (or the given `sequential` form of `fun`) differentiable
    in reverse mode (`jax.grad`, `vjp`, `jacrev`, to any order): the derivative is the VJP of
    `fun` restricted to the outputs with nonzero cotangents, as autodiff of `fun` itself (a
    zero cotangent times an infinite partial, an SVD's at repeated singular values, would give
    NaN), run member by member under vmap too, after recomputing `fun`'s forward pass. `fun`
    maps float arrays (a pytree) to float arrays. A `jax.custom_vjp`: no forward mode (`jvp`,
    `jacfwd`)."""
    sequential = sequential_when_batched(fun) if sequential is None else sequential

    @jax.custom_vjp
    def wrapped(*args):
        return sequential(*args)

    def fwd(*args):
        args = jax.custom_derivatives.custom_vjp_primal_tree_values(args)
        return wrapped(*args), args

    def bwd(args, cotangent):
        cts = jax.tree_util.tree_leaves(cotangent)
        live = [type(c) is not jax.custom_derivatives.SymbolicZero for c in cts]

        def live_vjp(a, live_cts):
            def live_outputs(*a):
                return [y for y, keep in zip(jax.tree_util.tree_leaves(fun(*a)), live) if keep]
            return jax.vjp(live_outputs, *a)[1](live_cts)

        return member_by_member(live_vjp)(args, [c for c, keep in zip(cts, live) if keep])

    wrapped.defvjp(fwd, bwd, symbolic_zeros=True)
    return wrapped


def _lu_solve_sequential():
    """jnp.linalg.solve(a, b) that under vmap never makes a batched LAPACK call: with `a`
    shared, the batched right-hand sides become columns of one solve (one factorisation);
    with `a` batched, member by member."""
    @jax.custom_batching.custom_vmap
    def solve(a, b):
        return jnp.linalg.solve(a, b)

    @solve.def_vmap
    def rule(axis_size, in_batched, a, b):
        a_batched, b_batched = in_batched
        if a_batched:
            b = b if b_batched else jnp.broadcast_to(b, (axis_size, *b.shape))
            return jax.lax.map(lambda ab: solve(*ab), (a, b)), True
        cols = jnp.moveaxis(b, 0, -1)                       # (n, ..., batch)
        x = solve(a, cols.reshape(cols.shape[0], -1))
        return jnp.moveaxis(x.reshape(cols.shape), -1, 0), True

    return solve


lu_solve = member_by_member(jnp.linalg.solve, _lu_solve_sequential())
lu_solve.__doc__ = """Solve a x = b (a (n, n), b (n,) or (n, k)) by LU with partial pivoting
(LAPACK); under vmap no batched LAPACK call (shared `a`: the right-hand sides as columns of
one solve; batched `a`: member by member); reverse-mode differentiable (`member_by_member`)."""


@sequential_when_batched
def cholesky_solve(a, b):
    """Solve a x = b for symmetric positive definite a by Cholesky (LAPACK); x is NaN where a
    is not positive definite (the factorisation's NaNs propagate)."""
    return jax.scipy.linalg.cho_solve((jnp.linalg.cholesky(a), True), b)


@sequential_when_batched
def cholesky_factor(a):
    """Lower Cholesky factor L of symmetric positive definite a (L L^T = a; LAPACK), NaN where
    a is not positive definite. For solver internals (not differentiable)."""
    return jnp.linalg.cholesky(a)


@sequential_when_batched
def cholesky_factor_solve(L, b):
    """Solve (L L^T) x = b given the lower Cholesky factor L (LAPACK triangular solves)."""
    return jax.scipy.linalg.cho_solve((L, True), b)


@sequential_when_batched
def complete_qr(a):
    """(Q, R) of the complete QR factorisation of a (LAPACK)."""
    return jnp.linalg.qr(a, mode="complete")


UNROLLED_SUBSTITUTION = 8     # up to this size substitution is written out element by element


def triangular_solve(r, b, lower):
    """Solve r x = b for triangular r (k, k), b (k,) or (k, m) by substitution in plain array
    operations: differentiable, no LAPACK call. Up to `UNROLLED_SUBSTITUTION` unknowns written
    out element by element (pure elementwise arithmetic under vmap); beyond, one
    `lax.fori_loop` over the rows (an unrolled k = 96 solve was 9000 operations, most of a
    condensed LGL-mesh step's program)."""
    k = r.shape[0]
    if k > UNROLLED_SUBSTITUTION:
        def row(step, x):
            i = step if lower else k - 1 - step
            return x.at[i].set((b[i] - r[i] @ x) / r[i, i])     # x is 0 where not yet solved
        return jax.lax.fori_loop(0, k, row, jnp.zeros_like(b))
    x = [None] * k
    order = range(k) if lower else reversed(range(k))
    for i in order:
        known = [j for j in range(k) if x[j] is not None]
        acc = b[i] - sum(r[i, j] * x[j] for j in known) if known else b[i]
        x[i] = acc / r[i, i]
    return jnp.stack(x)


@sequential_when_batched
def block_tridiagonal_solve(diag, sub, b):
    """Solve A x = b for symmetric positive definite block-tridiagonal A: diag (m, k, k) its
    diagonal blocks A_ii, sub (m - 1, k, k) the blocks below them A_{i+1,i}, b (m, k). Block
    Cholesky (L_ii L_ii^T = A_ii - L_{i,i-1} L_{i,i-1}^T, L_{i+1,i} = A_{i+1,i} L_ii^-T; Golub
    & Van Loan 2013, §4.5.3), then the two block substitutions: m k^3 work instead of
    (m k)^3 / 3. x is NaN where A is not positive definite (the factorisation's NaNs
    propagate), as `cholesky_solve`'s."""
    tri = jax.scipy.linalg.solve_triangular

    def step(carry, blocks):
        L_prev, y_prev = carry
        a, below, rhs = blocks
        l_below = tri(L_prev, below.T, lower=True).T            # A_{i,i-1} L_{i-1}^-T
        L = jnp.linalg.cholesky(a - l_below @ l_below.T)
        y = tri(L, rhs - l_below @ y_prev, lower=True)
        return (L, y), (L, l_below, y)

    first = jnp.linalg.cholesky(diag[0])
    y0 = tri(first, b[0], lower=True)
    _, (Ls, lows, ys) = jax.lax.scan(step, (first, y0), (diag[1:], sub, b[1:]))
    Ls = jnp.concatenate([first[None], Ls])
    ys = jnp.concatenate([y0[None], ys])

    def back(x_next, blocks):
        L, l_next, y = blocks                  # L_ii, L_{i+1,i}, y_i
        x = tri(L.T, y - l_next.T @ x_next, lower=False)
        return x, x

    x_last = tri(Ls[-1].T, ys[-1], lower=False)
    _, xs = jax.lax.scan(back, x_last, (Ls[:-1], lows, ys[:-1]), reverse=True)
    return jnp.concatenate([xs, x_last[None]])


# Small matrices as nested lists (rows) of node arrays, per-problem scalars or Python numbers
# (`jaxlpm.dynamics.stm.ya_entries`); the Python number 0 is a structural zero, and products
# with it are skipped. Under vmap each entry is one (batch, n) or (batch,) array, so every
# product below is a fused multiply-add over the batch and the nodes (no small dots, no
# (k, k, n) arrays, which XLA:CPU runs slowly).

def structural_zero(x) -> bool:
    """Whether x is the Python number 0 (a structural zero of a nested-list matrix)."""
    return isinstance(x, (int, float)) and x == 0


def entries_sum(terms):
    """Sum of arrays or numbers; the structural zero 0.0 when there are none."""
    return functools.reduce(operator.add, terms) if terms else 0.0


def entries_mv(M, v):
    """M v for a nested-list M and a list v, skipping structural zeros."""
    return [entries_sum([m * x for m, x in zip(row, v)
                         if not (structural_zero(m) or structural_zero(x))]) for row in M]


def entries_transpose(M):
    """M^T of a nested-list matrix."""
    return [list(col) for col in zip(*M)]


def entries_mm(A, B):
    """A B of nested-list matrices, skipping structural zeros."""
    return entries_transpose([entries_mv(A, col) for col in entries_transpose(B)])


def entries_at(M, i):
    """The entries of a nested-list matrix at index i of their last axis (numbers kept)."""
    return [[x if isinstance(x, (int, float)) else x[..., i] for x in row] for row in M]


def materialized(*xs):
    """The arrays xs (equal shapes), each computed once and stored.

    XLA:CPU has no multi-output loop fusion and fuses a unary producer (sin, cos) into every
    consumer fusion, so a node array that feeds dozens of fusions has its whole expression,
    transcendentals included, re-evaluated in each; `lax.optimization_barrier` is removed
    before fusion on CPU. A product with the identity (exact in floating point for finite
    values; a non-finite one makes the others NaN) is a fusion boundary: its operands are
    evaluated once into a buffer.
    """
    stacked = jnp.stack(xs)
    return tuple(jnp.tensordot(jnp.eye(len(xs), dtype=stacked.dtype), stacked, axes=1))
