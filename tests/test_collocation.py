"""Tests of jaxlpm.collocation: nodes, weights, barycentric operators and Grid.

Tolerances are written in units of EPS (float64 machine epsilon) times a size factor;
each states why that factor bounds the rounding of the computation under test.
"""

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp
import numpy as np
import pytest
from numpy.polynomial import legendre as npleg
from scipy.special import roots_jacobi

from jaxlpm.collocation import (
    Grid,
    barycentric_interpolate,
    barycentric_weights,
    differentiation_matrix,
    integration_matrix,
    interpolation_matrix,
    lg,
    lg_nodes_weights,
    lgl,
    lgl_nodes_weights,
    lgr,
    lgr_nodes_weights,
    make_grid,
)
from jaxlpm.collocation.grid import _host_operators
from jaxlpm.collocation.legendre import legendre, legendre_table

EPS = np.finfo(np.float64).eps
SCHEMES = ("LGL", "LG", "LGR")
NODE_BUILDERS = {"LGL": lgl_nodes_weights, "LG": lg_nodes_weights, "LGR": lgr_nodes_weights}
# Sizes in collocation points; 257 is the N = 256 LGL grid (and K = 257 for LG/LGR).
SIZES = (3, 8, 65, 257)
PAD_LEN = 260  # one padded length for all sizes: one compilation of the jitted evaluators
interp_many = jax.jit(jax.vmap(barycentric_interpolate, in_axes=(None, None, None, 0)))
grad_many = jax.jit(
    jax.vmap(jax.grad(barycentric_interpolate, argnums=(2, 3)), in_axes=(None, None, None, 0))
)


def pad_to(length, x, b, v):
    """Pad support with x = 10 (far outside [-1, 1]), b = 0 and arbitrary values."""
    extra = length - x.size
    return (
        np.concatenate([x, np.full(extra, 10.0)]),
        np.concatenate([b, np.zeros(extra)]),
        np.concatenate([v, np.full((extra, *v.shape[1:]), 123.0)]),
    )


def exact_degree(scheme, n):
    """Highest polynomial degree integrated exactly by the scheme with n points."""
    return {"LGL": 2 * n - 3, "LG": 2 * n - 1, "LGR": 2 * n - 2}[scheme]


def legendre_series(c, x):
    """p(x) = sum_m c_m P_m(x) and p'(x) by the Legendre recurrences (no barycentric code)."""
    p, dp = legendre_table(len(c) - 1, np.asarray(x, dtype=np.float64))
    return c @ p, c @ dp


def test_legendre_matches_numpy():
    x = np.linspace(-1.0, 1.0, 101)
    for n in (0, 1, 2, 7, 40):
        p, dp = legendre(n, x)
        e = np.eye(n + 1)[n]
        # Both sides run O(n)-step recurrences / Clenshaw sums on values of size |P'_n| <= n(n+1)/2.
        assert np.max(np.abs(p - npleg.legval(x, e))) <= 4 * (n + 1) * EPS
        assert np.max(np.abs(dp - npleg.legval(x, npleg.legder(e)))) <= 4 * (n + 1) ** 3 * EPS


@pytest.mark.parametrize("n", (3, 4, 9, 64, 65, 257))
@pytest.mark.parametrize("scheme", SCHEMES)
def test_nodes_weights_against_scipy(scheme, n):
    x, w = NODE_BUILDERS[scheme](n)
    if scheme == "LGL":
        xi, wi = roots_jacobi(n - 2, 1.0, 1.0)
        ref_x = np.concatenate(([-1.0], xi, [1.0]))
        nn = n - 1
        ref_w = np.concatenate(([2 / (nn * (nn + 1))], wi / (1 - xi**2), [2 / (nn * (nn + 1))]))
    elif scheme == "LG":
        ref_x, ref_w = npleg.leggauss(n)
    else:
        xi, wi = roots_jacobi(n - 1, 0.0, 1.0)
        ref_x = np.concatenate(([-1.0], xi))
        ref_w = np.concatenate(([2 / n**2], wi / (1 + xi)))
    assert x.shape == w.shape == (n,)
    assert np.all(np.diff(x) > 0)
    # Both node sets are Newton-polished roots in [-1, 1]: a few ulps of 1 apart at most.
    assert np.max(np.abs(x - ref_x)) <= 4 * EPS
    # scipy/numpy weights carry O(n eps) absolute error (their sum misses 2 by up to ~1.1 n eps).
    assert np.max(np.abs(w - ref_w)) <= 4 * n * EPS


@pytest.mark.parametrize("n", SIZES)
@pytest.mark.parametrize("scheme", SCHEMES)
def test_quadrature_exact_to_degree_on_legendre(scheme, n):
    x, w = NODE_BUILDERS[scheme](n)
    deg = exact_degree(scheme, n)
    p, _ = legendre_table(deg + 1, x)
    err = p @ w - 2.0 * (np.arange(deg + 2) == 0)
    # n terms w_i P_m(x_i), |P_m| <= 1 from an m <= 2n step recurrence (<= 2n eps), sum w = 2.
    assert np.max(np.abs(err[: deg + 1])) <= 4 * n * EPS
    # One degree higher the rule has a nonzero error (about 0.08 at n = 257, 1 at n = 3).
    assert abs(err[deg + 1]) > 1e-2


@pytest.mark.parametrize("n", (3, 4, 5, 8))
@pytest.mark.parametrize("scheme", SCHEMES)
def test_quadrature_exact_to_degree_on_monomials(scheme, n):
    x, w = NODE_BUILDERS[scheme](n)
    deg = exact_degree(scheme, n)
    m = np.arange(deg + 2)
    exact = np.where(m % 2 == 0, 2.0 / (m + 1), 0.0)
    err = (x[None, :] ** m[:, None]) @ w - exact
    # |x^m| <= 1, sum w = 2 and n <= 8 terms: a few eps per term.
    assert np.max(np.abs(err[: deg + 1])) <= 4 * n * EPS
    # The monomial one degree higher misses by >= 2e-4 here (n = 8), far above the tolerance.
    assert abs(err[deg + 1]) > 1e-6


@pytest.mark.parametrize("n", SIZES)
@pytest.mark.parametrize("scheme", SCHEMES)
def test_differentiation_exact_on_state_polynomials(scheme, n):
    g = make_grid(scheme, n)
    support, points, d = (np.asarray(a) for a in (g.support, g.points, g.D))
    ns = support.size
    assert d.shape == (n, ns)
    c = np.random.default_rng(n).standard_normal(ns)
    v, _ = legendre_series(c, support)
    _, dv = legendre_series(c, points)
    # D v sums n_s products of entries of size up to ~n^2 (D_ii by an n-term negative sum) and the
    # reference runs an n-step derivative recurrence: O(n eps) relative to sum_j |D_ij||v_j|.
    tol = ns * EPS * np.max(np.abs(d) @ np.abs(v))
    assert np.max(np.abs(d @ v - dv)) <= tol
    # Degree n_s is beyond the state polynomial: D must miss it.
    v_hi, _ = legendre_series(np.eye(ns + 1)[ns], support)
    _, dv_hi = legendre_series(np.eye(ns + 1)[ns], points)
    assert np.max(np.abs(d @ v_hi - dv_hi)) > 1e-3


@pytest.mark.parametrize("n", (3, 9, 65, 257))
def test_lgl_matches_corrected_mei_closed_form(n):
    g = lgl(n)
    t = np.asarray(g.points)
    nn = n - 1
    pn, _ = legendre(nn, t)
    diff = t[:, None] - t[None, :]
    np.fill_diagonal(diff, 1.0)
    mei = pn[:, None] / (pn[None, :] * diff)
    np.fill_diagonal(mei, 0.0)
    mei[0, 0], mei[-1, -1] = -nn * (nn + 1) / 4, nn * (nn + 1) / 4
    # The closed form is for the exact nodes, ours for the rounded ones: a node shift of eps/2
    # changes b_j / b_i relatively by ~ eps / (min gap) with min gap ~ 4.9 / N^2 (near ±1), so
    # off-diagonal entries agree to N^2 eps / 2 relatively (observed 0.06 N^2 eps); the negative-sum
    # diagonal inherits that relative error on its row, sum_j |D_ij|.
    err = np.abs(np.asarray(g.D) - mei)
    scale = np.where(np.eye(n, dtype=bool), np.abs(mei).sum(axis=1, keepdims=True), np.abs(mei))
    tol = nn**2 * EPS / 2 * scale
    assert np.all(err <= tol)

    # Basis compared at midpoints between nodes: there P'_N(s) is not near a zero, so the closed
    # form has no cancellation and keeps O(N eps) relative accuracy.
    s = (t[1:] + t[:-1]) / 2
    ps, dps = legendre(nn, s)
    phi = (s[:, None] ** 2 - 1) * dps[:, None] / (nn * (nn + 1) * pn[None, :])
    phi = phi / (s[:, None] - t[None, :])
    x_pad, b_pad, _ = pad_to(PAD_LEN, t, np.asarray(g.support_bary), t)
    s_pad = np.concatenate([s, np.zeros(PAD_LEN - s.size)])
    basis = np.asarray(interp_many(x_pad, b_pad, np.eye(PAD_LEN), s_pad))[: s.size, :n]
    host = interpolation_matrix(t, np.asarray(g.support_bary), s)
    # Same exact-vs-rounded-node effect: l_i(s) moves by ~ |D| eps ~ N^2 eps / 4.9 (observed
    # <= 0.08 N^2 eps).
    assert np.max(np.abs(basis - phi)) <= nn**2 * EPS / 2
    assert np.max(np.abs(host - phi)) <= nn**2 * EPS / 2


@pytest.mark.parametrize("n", SIZES)
@pytest.mark.parametrize("scheme", SCHEMES)
def test_interpolation_exact_on_polynomials(scheme, n):
    """Padded to one shape (b = 0 beyond the live nodes) so that a single compilation serves all."""
    g = make_grid(scheme, n)
    rng = np.random.default_rng(n + 7)
    t = rng.uniform(-1, 1, 64)
    for nodes, bary in ((g.support, g.support_bary), (g.points, g.point_bary)):
        nodes_np, bary_np = np.asarray(nodes), np.asarray(bary)
        c = rng.standard_normal(nodes_np.size)
        v, _ = legendre_series(c, nodes_np)
        vt, _ = legendre_series(c, t)
        x_pad, b_pad, v_pad = pad_to(PAD_LEN, nodes_np, bary_np, v)
        t_all = np.concatenate([t, x_pad[: nodes_np.size], np.zeros(PAD_LEN - nodes_np.size)])
        got = np.asarray(interp_many(x_pad, b_pad, v_pad, t_all))
        # Second barycentric form is forward stable (Higham 2004: (3n+4) eps Lambda_n |v|); the
        # observed error is below n eps max|v|, 4x margin for the n-step reference recurrence.
        tol = 4 * nodes_np.size * EPS * np.max(np.abs(v))
        assert np.max(np.abs(got[:64] - vt)) <= tol
        assert np.max(np.abs(interpolation_matrix(nodes_np, bary_np, t) @ v - vt)) <= tol
        # At the nodes the interpolant returns the data bit for bit.
        np.testing.assert_array_equal(got[64 : 64 + nodes_np.size], v)


def test_interpolation_trailing_dims_and_padding():
    g = lgr(17)
    rng = np.random.default_rng(3)
    x, b = np.asarray(g.support), np.asarray(g.support_bary)
    v = rng.standard_normal((x.size, 3, 2))
    t = np.concatenate([rng.uniform(-1, 1, 20), x])
    ref = np.asarray(interp_many(x, b, v, t))
    got = np.asarray(interp_many(*pad_to(x.size + 9, x, b, v), t))
    assert ref.shape == got.shape == (t.size, 3, 2)
    # Padded terms are exact zeros; only the summation order of the live terms may change.
    assert np.max(np.abs(got - ref)) <= 4 * x.size * EPS * np.max(np.abs(v))
    np.testing.assert_array_equal(ref[20:], v)
    np.testing.assert_array_equal(got[20:], v)


@pytest.mark.parametrize(("scheme", "n"), (("LGL", 9), ("LGL", 257), ("LG", 8), ("LGR", 256)))
def test_interpolation_gradients_at_nodes(scheme, n):
    """d/dt p(x_k) = (D_full v)_k; LGL with odd n puts a node at 0 where sum_{j!=k} c_j = 0."""
    g = make_grid(scheme, n)
    x, b = np.asarray(g.support), np.asarray(g.support_bary)
    v = np.random.default_rng(5).standard_normal(x.size)
    d_full = differentiation_matrix(x, b)
    # Same O(n eps sum_j |D_kj||v_j|) rounding as the differentiation-matrix test.
    tol = x.size * EPS * np.max(np.abs(d_full) @ np.abs(v))
    t_pad = np.concatenate([x, np.zeros(PAD_LEN - x.size)])
    for args in ((x, b, v, x), (*pad_to(PAD_LEN, x, b, v), t_pad)):
        dv, dt = (np.asarray(a)[: x.size] for a in grad_many(*args))
        dv = dv[:, : x.size]
        assert np.all(np.isfinite(dv)) and np.all(np.isfinite(dt))
        assert np.max(np.abs(dt - d_full @ v)) <= tol
        # At node k the interpolant is v_k exactly, so its gradient in v is exactly e_k.
        np.testing.assert_array_equal(dv, np.eye(x.size))


@pytest.mark.parametrize("n", SIZES)
@pytest.mark.parametrize("scheme", SCHEMES)
def test_integration_matrix_exact(scheme, n):
    g = make_grid(scheme, n)
    t, a = np.asarray(g.points), np.asarray(g.integration)
    assert a.shape == (n, n)
    c = np.random.default_rng(n + 11).standard_normal(n)
    v, _ = legendre_series(c, t)
    ic = npleg.legint(c, lbnd=-1)
    # A = W V^{-1} with a Legendre Vandermonde of condition O(sqrt(n)) at Gauss-type nodes;
    # observed error is below 0.1 n eps max|v|.
    assert np.max(np.abs(a @ v - npleg.legval(t, ic))) <= n * EPS * np.max(np.abs(v))
    if scheme == "LGL":
        # Integral to +1 is the LGL quadrature; weights are accurate to a few eps (test above).
        assert np.max(np.abs(a[-1] - np.asarray(g.weights))) <= n * EPS
    # Degree n is outside the Lagrange space on n points: A must miss it.
    v_hi, _ = legendre_series(np.eye(n + 1)[n], t)
    ic_hi = npleg.legint(np.eye(n + 1)[n], lbnd=-1)
    assert np.max(np.abs(a @ v_hi - npleg.legval(t, ic_hi))) > 1e-4
    np.testing.assert_allclose(integration_matrix(t), a, rtol=0, atol=0)


@pytest.mark.parametrize("n", SIZES)
@pytest.mark.parametrize("scheme", SCHEMES)
def test_final_state_by_quadrature(scheme, n):
    """x(1) = x(-1) + sum_k w_k (D x)_k for a state polynomial of degree n_s - 1."""
    g = make_grid(scheme, n)
    support = np.asarray(g.support)
    c = np.random.default_rng(n + 13).standard_normal(support.size)
    v, _ = legendre_series(c, support)
    ends, _ = legendre_series(c, np.array([-1.0, 1.0]))
    d = np.asarray(g.D)
    got = ends[0] + np.asarray(g.weights) @ (d @ v)
    # Quadrature of D v: weights sum to 2, so the D v error bound carries over (times 2).
    assert abs(got - ends[1]) <= 2 * support.size * EPS * np.max(np.abs(d) @ np.abs(v))


def test_grid_layout_and_pytree():
    for grid, support_len in ((lgl(5), 5), (lg(4), 5), (lgr(4), 5)):
        pts, sup = np.asarray(grid.points), np.asarray(grid.support)
        assert grid.points.dtype == jnp.float64 and sup.size == support_len
        assert grid.D.shape == (grid.n, support_len)
        assert grid.point_bary.shape == (grid.n,) and grid.support_bary.shape == (support_len,)
        if grid.scheme == "LGL":
            np.testing.assert_array_equal(sup, pts)
        elif grid.scheme == "LG":
            np.testing.assert_array_equal(sup, np.concatenate(([-1.0], pts)))
        else:
            np.testing.assert_array_equal(sup, np.concatenate((pts, [1.0])))
        # fixed by (scheme, n): a leafless pytree (static under jit, never copied by vmap)
        leaves, treedef = jax.tree_util.tree_flatten(grid)
        assert leaves == []
        rebuilt = jax.tree_util.tree_unflatten(treedef, leaves)
        assert rebuilt == grid and hash(rebuilt) == hash(make_grid(grid.scheme, grid.n))
        assert grid != make_grid(grid.scheme, grid.n + 1)
    g = lg(9)
    both = jax.jit(lambda gr, v, u: (gr.interpolate_state(v, 0.3), gr.interpolate_control(u, 0.3)))
    state, control = both(g, jnp.sin(g.support), jnp.cos(g.points))
    sup, pts = np.asarray(g.support), np.asarray(g.points)
    ref_state = interpolation_matrix(sup, np.asarray(g.support_bary), 0.3) @ np.sin(sup)
    ref_control = interpolation_matrix(pts, np.asarray(g.point_bary), 0.3) @ np.cos(pts)
    # jit and host evaluate the same <= 10-term barycentric sums of O(1) values.
    assert abs(float(state) - ref_state[0]) <= 16 * EPS
    assert abs(float(control) - ref_control[0]) <= 16 * EPS
    assert isinstance(make_grid("LG", 1), Grid) and make_grid("LG", 1).D.shape == (1, 2)


@pytest.mark.parametrize(
    ("factory", "scheme", "bad", "minimum"),
    (
        (lgl, "LGL", 2, 3),
        (lg, "LG", 0, 1),
        (lgr, "LGR", 1, 2),
        (lgl, "LGL", 5.0, 3),
        (lg, "LG", True, 1),
        (lgr, "LGR", "4", 2),
    ),
)
def test_invalid_sizes_raise(factory, scheme, bad, minimum):
    with pytest.raises(ValueError, match=rf"{scheme}.*>= {minimum}, got {bad!r}"):
        factory(bad)


def test_unknown_scheme_raises():
    with pytest.raises(ValueError, match="scheme"):
        make_grid("CGL", 9)


def test_host_helpers_on_generic_nodes():
    x = np.linspace(-1.0, 1.0, 7)
    b = barycentric_weights(x)
    # Equispaced weights are (-1)^j binom(6, j) / 20 after normalisation; 6-factor products of
    # O(1) scaled differences round to a few eps.
    ref = np.array([1, -6, 15, -20, 15, -6, 1], dtype=np.float64) / 20
    assert np.max(np.abs(b - ref)) <= 8 * EPS
    assert barycentric_weights(np.array([0.25])).tolist() == [1.0]


def test_operator_cache_and_float32_refused():
    _host_operators.cache_clear()
    first = lgl(65)
    second = lgl(65)
    info = _host_operators.cache_info()
    assert (info.misses, info.hits) == (1, 1)
    assert _host_operators("LGL", 65) is _host_operators("LGL", 65)
    assert not _host_operators("LGL", 65)["D"].flags.writeable
    np.testing.assert_array_equal(np.asarray(first.D), np.asarray(second.D))
    jax.config.update("jax_enable_x64", False)
    try:
        with pytest.raises(ValueError, match="float64"):
            lgl(65)
    finally:
        jax.config.update("jax_enable_x64", True)
