"""The condensed Newton-KKT step on many-segment LGR meshes (`jaxlpm.nlp.condensed_segments`):
its local basis and block-banded reduced Hessian give the step of the dense condensed solve
and of the dense KKT LU; the block-tridiagonal Cholesky against a dense solve; a mesh's
segment-by-segment D against its matrix."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxlpm as lpm
from jaxlpm.cases.mei2010 import dispersion
from jaxlpm.linalg import block_tridiagonal_solve
from jaxlpm.nlp import CondensedSecondOrder, DenseKKT
from jaxlpm.nlp.condensed_segments import (SegmentedCondensed, condensed_linear_algebra,
                                            segments_apply)
from jaxlpm.nlp.transcription import equality, objective
from jaxlpm.solvers.transfer import linear_warm_start, transfer_ocp


def _block_tridiagonal(rng, m, k):
    """A random symmetric positive definite block-tridiagonal matrix: (dense, diag, sub)."""
    A = np.zeros((m * k, m * k))
    for i in range(m):
        block = rng.normal(size=(k, k))
        A[i * k:(i + 1) * k, i * k:(i + 1) * k] = block + block.T + 4.0 * k * np.eye(k)
        if i:
            below = rng.normal(size=(k, k))
            A[i * k:(i + 1) * k, (i - 1) * k:i * k] = below
            A[(i - 1) * k:i * k, i * k:(i + 1) * k] = below.T
    diag = np.stack([A[i * k:(i + 1) * k, i * k:(i + 1) * k] for i in range(m)])
    sub = np.stack([A[(i + 1) * k:(i + 2) * k, i * k:(i + 1) * k] for i in range(m - 1)])
    return A, diag, sub


def test_block_tridiagonal_solve_is_a_dense_solve():
    """Against LAPACK's dense solve of the same matrix, alone and vmapped (member by member),
    to round-off (the matrix is diagonally dominant: condition number below 10); NaN for a
    matrix that is not positive definite."""
    rng = np.random.default_rng(1)
    A, diag, sub = _block_tridiagonal(rng, 5, 4)
    b = rng.normal(size=(2, 5, 4))
    x = np.asarray(jax.jit(jax.vmap(block_tridiagonal_solve, (None, None, 0)))(diag, sub, b))
    for xi, bi in zip(x, b):
        np.testing.assert_allclose(xi.ravel(), np.linalg.solve(A, bi.ravel()), atol=1e-13)
    bad = diag.copy()
    bad[3] = -bad[3]
    assert np.all(np.isnan(np.asarray(block_tridiagonal_solve(bad, sub, b[0]))[3:]))


@pytest.mark.parametrize("scheme", ["LGR", "LG", "LGL"])
def test_mesh_differentiate_is_its_block_matrix(scheme):
    """`Mesh.differentiate` (segment by segment) equals D @ values with the mesh's block D,
    on unequal segments, to round-off."""
    mesh = lpm.make_mesh(scheme, 3, 5, breaks=[-1.0, -0.3, 0.2, 1.0])
    values = np.random.default_rng(2).normal(size=(mesh.n_rows, 6))
    ref = np.asarray(mesh.D) @ values
    np.testing.assert_allclose(np.asarray(mesh.differentiate(jnp.asarray(values))), ref,
                               atol=1e-13 * np.max(np.abs(ref)))


@pytest.fixture(scope="module")
def member():
    """A two-body transfer of the robustness dispersion (e 0.6, 2.3 revolutions)."""
    batch = dispersion(jax.random.key(3), 4, "two-body")
    return jax.tree_util.tree_map(lambda x: x[1] if np.ndim(x) and np.shape(x)[0] == 4 else x,
                                  batch)


def assert_same_kkt_steps(member, mesh, condensed):
    """At the warm start, with the first multipliers of the dense condensed solve (so the
    point Hessians hold the two-body dynamics' second derivatives), `DenseKKT` and each
    linear algebra of `condensed` (ocp, z -> instance) solve the same KKT system, with and
    without regularisation dw: the null-space step of a positive definite reduced Hessian
    does not depend on the basis, so steps and multipliers agree to the system's round-off
    (the dense LU and the dense condensed solve agree to about 1e-11 of the step: 1e-9 is
    asserted)."""
    ocp, _, _ = transfer_ocp(member, mesh)
    z, _ = linear_warm_start(member, ocp, mesh)

    @jax.jit
    def steps(z):
        lam = CondensedSecondOrder(ocp, mesh, z).first_multipliers(z)
        g, c = jax.grad(objective)(z, ocp, mesh), equality(z, ocp, mesh)
        out = []
        for la in (DenseKKT(ocp, mesh, z), *(make(ocp, z) for make in condensed)):
            prep = la.prepare(z, lam)
            H = la.hessian(prep, z, lam)
            out.append([la.solve(prep, H, g, c, dw, 0.0) for dw in (0.0, 0.5)])
        return out

    dense, *others = steps(z)
    for k in range(2):
        p_ref, lam_ref, ok = dense[k]
        assert bool(ok)
        for p, lam_new, ok in (other[k] for other in others):
            assert bool(ok)
            np.testing.assert_allclose(p, p_ref, atol=1e-9 * np.max(np.abs(p_ref)))
            np.testing.assert_allclose(lam_new, lam_ref, atol=1e-9 * np.max(np.abs(lam_ref)))


@pytest.mark.parametrize("segments, points", [(5, 6)])
def test_the_segmented_step_is_the_condensed_and_the_dense_step(member, segments, points):
    """The three linear algebras give the same step (`assert_same_kkt_steps`). 5 segments
    (odd) exercise the band's identity block; the refinement tests run even counts
    (tests/test_meshes.py checks whole refined solves on LGR meshes, which take this solve
    from 4 segments, against the LG and LGL ones)."""
    mesh = lpm.lgr_mesh(segments, points)
    ocp, _, _ = transfer_ocp(member, mesh)
    assert segments_apply(ocp, mesh)
    assert isinstance(condensed_linear_algebra(ocp, mesh), SegmentedCondensed)
    assert_same_kkt_steps(member, mesh, [lambda ocp, z: CondensedSecondOrder(ocp, mesh, z),
                                         lambda ocp, z: SegmentedCondensed(ocp, mesh, z)])


@pytest.mark.parametrize("make_mesh", [lpm.lg_mesh, lpm.lgl_mesh])
def test_the_condensed_step_on_lg_and_lgl_meshes_is_the_dense_step(member, make_mesh):
    """`CondensedSecondOrder` on an LG mesh (interior break velocities by the quadrature
    recursion, each segment's position quadrature row a condition) and an LGL mesh (the
    linkage rows conditions) gives the dense LU's step and multipliers
    (`assert_same_kkt_steps`) on 3 unequal segments of 6 points. The condensed basis is
    formed at z = 0 and used at the warm start: its null space does not depend on z."""
    mesh = make_mesh(3, 6, np.array([-1.0, -0.4, 0.3, 1.0]))
    assert_same_kkt_steps(member, mesh, [lambda ocp, z: CondensedSecondOrder(ocp, mesh)])


@pytest.mark.parametrize("k", [5, 20])
@pytest.mark.parametrize("lower", [True, False])
def test_triangular_solve_is_a_substitution(k, lower):
    """`triangular_solve` (unrolled up to 8 unknowns, a loop beyond) against NumPy's dense
    solve, for a vector and a matrix right-hand side (round-off of a well-conditioned
    system), and its derivative in the right-hand side (the solve is linear in b: the VJP of
    x . c is r^-T c)."""
    from jaxlpm.linalg import triangular_solve
    rng = np.random.default_rng(k)
    r = rng.normal(size=(k, k)) + 2.0 * k * np.eye(k)
    r = np.tril(r) if lower else np.triu(r)
    for b in (rng.normal(size=k), rng.normal(size=(k, 3))):
        np.testing.assert_allclose(triangular_solve(jnp.asarray(r), jnp.asarray(b), lower),
                                   np.linalg.solve(r, b), rtol=1e-12, atol=1e-14)
    c = rng.normal(size=k)
    grad = jax.grad(lambda b: triangular_solve(jnp.asarray(r), b, lower) @ c)(jnp.zeros(k))
    np.testing.assert_allclose(grad, np.linalg.solve(r.T, c), rtol=1e-12, atol=1e-14)
