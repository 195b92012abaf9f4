"""Newton-KKT solver and the general transcription (issue 3).

Node counts stay modest (compile time dominates). The N = 64 acceptance checks (the nonlinear
and J2 transfers flown through the nonlinear model miss by well under 1 m) run in
tests/test_verify.py on the reproduction's own results, so they compile once.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.integrate
import scipy.linalg

import jaxlpm as lpm
from jaxlpm import Status
from jaxlpm.cases import mei2010
from jaxlpm.collocation.padded import PaddedGrid, grid_rows, pad_grid
from jaxlpm.dynamics import hcw_matrix
from jaxlpm.nlp import OptimalControlProblem, PathPenalty
from jaxlpm.nlp import transcription as tr
from jaxlpm.nlp import newton_kkt
from jaxlpm.solvers.transfer import newton_transfer

# small grids for speed: solutions that converge unresolved are accepted (conftest)
pytestmark = pytest.mark.usefixtures("loose_accuracy")

# XLA's backend optimisation is most of these solvers' compile time and buys little for
# functions run a few times: compile the tests' solves without it (as the CLI's one-off solves).
QUICK = {"xla_backend_optimization_level": 0}


def quick(fn, *args):
    """fn(*args) through jit, compiled at backend optimisation level 0."""
    return jax.jit(fn).lower(*args).compile(QUICK)(*args)


# ---------------------------------------------------------------- a generic test problem


def _hcw_dynamics(s, x, u, data, p):
    """HCW in units of 1/n (time) and the transfer's length: x' = A x + [0; u]."""
    return hcw_matrix(1.0) @ x + jnp.concatenate([jnp.zeros(3), u])


def _energy(s, x, u, data, p):
    return 0.5 * jnp.dot(u, u)


def _fixed_ends(x0, xf, sf, p):
    return jnp.concatenate([x0 - p["x0"], xf - p["xf"]])


HCW_X0 = np.array([1.0, 1.0, 0.5, 0.0, -0.5, 0.1])
HCW_T = 3.0


def _hcw_ocp():
    params = {"x0": jnp.asarray(HCW_X0), "xf": jnp.zeros(6)}
    return OptimalControlProblem(n_x=6, n_u=3, dynamics=_hcw_dynamics, running_cost=_energy,
                                 boundary=_fixed_ends, s0=jnp.array(0.0), sf=jnp.array(HCW_T),
                                 params=params)


def _hcw_analytic_costate(t):
    """Minimum-energy HCW transfer (PMP): u = -B^T lam, lam(t) = exp(-A^T t) lam0 with
    lam0 = G^-1 (Phi(T) x0 - xf), G = int_0^T Phi(T - s) B B^T exp(-A^T s) ds."""
    A = np.asarray(hcw_matrix(1.0))
    B = np.vstack([np.zeros((3, 3)), np.eye(3)])
    G = scipy.integrate.quad_vec(
        lambda s: scipy.linalg.expm(A * (HCW_T - s)) @ B @ B.T @ scipy.linalg.expm(-A.T * s),
        0.0, HCW_T, epsabs=1e-14, epsrel=1e-14)[0]
    lam0 = np.linalg.solve(G, scipy.linalg.expm(A * HCW_T) @ HCW_X0)
    return np.stack([scipy.linalg.expm(-A.T * ti) @ lam0 for ti in t])


# multi-segment meshes (issue 19): 3 unequal segments of 10 points, breaks off the grid's
# symmetry so that a join's costate is not helped by it
MESH_BREAKS = (-1.0, -0.45, 0.3, 1.0)
MESHES = ("LGL-mesh", "LG-mesh", "LGR-mesh")


def _grid(name, points, segment_points, breaks=MESH_BREAKS):
    """lpm.make_grid(name, points), or for "<scheme>-mesh" the scheme's mesh on `breaks`
    with `segment_points` per segment, or for "LGL-padded" lgl(points) padded with 5 rows
    (`jaxlpm.collocation.padded`)."""
    if name.endswith("-mesh"):
        return lpm.make_mesh(name[:-5], len(breaks) - 1, segment_points, breaks)
    if name == "LGL-padded":
        return pad_grid(points, points + 5)
    return lpm.make_grid(name, points)


def _live_rows(grid, values):
    """A padded grid's result at the grid's own collocation points (others: as they are)."""
    return values[grid_rows(int(grid.live), grid.n)] if isinstance(grid, PaddedGrid) else values


@pytest.fixture(scope="module")
def hcw_solutions():
    ocp = _hcw_ocp()
    out = {}
    for scheme in ("LGL", "LG", "LGR", "LGL-padded") + MESHES:
        grid = _grid(scheme, 16, 10)
        res = quick(lambda o, z: newton_kkt(o, grid, z), ocp,
                    jnp.zeros(tr.n_variables(ocp, grid)))
        out[scheme] = (grid, res)
    return ocp, out


@pytest.mark.parametrize("scheme", ["LGL", "LG", "LGR", "LGL-padded", *MESHES])
def test_structured_derivatives_equal_autodiff(scheme):
    """The Jacobian and Lagrangian Hessian assembled from the collocation structure equal
    dense autodiff of the whole NLP (nonlinear dynamics, cost, boundary and terminal terms,
    free final s, path constraints with their augmented-Lagrangian terms, on meshes the
    quadrature and linkage rows, on a padded grid the padding's pinning rows and cost: every
    block the assembly treats separately)."""
    def dyn(s, x, u, d, p):
        return jnp.concatenate([x[1:] * u[0], jnp.sin(x[:1]) + s * u[1] * x[0]])

    def cost(s, x, u, d, p):
        return 0.5 * u @ u + 0.1 * x[0] ** 2 * u[0]

    def bc(x0, xf, sf, p):
        return jnp.concatenate([x0 - 1.0, (xf * sf)[:1] ** 2])

    def term(x0, xf, sf, p):
        return sf**2 * xf[0] + x0[1] * xf[2]

    def path(s, x, u, d, p):
        return jnp.stack([x[0] * u[1] - 0.3, u[0] ** 2 - x[2]])

    def unit(s, x, u, d, p):
        return (u @ u - 1.0)[None]

    ocp = OptimalControlProblem(n_x=3, n_u=2, dynamics=dyn, running_cost=cost, boundary=bc,
                                s0=jnp.array(0.2), sf=jnp.array(1.7), terminal_cost=term,
                                free_final=True, path=path, path_equality=unit)
    grid = _grid(scheme, 5, 4, breaks=(-1.0, -0.2, 1.0))
    rng = np.random.default_rng(0)
    ocp = ocp.replace(penalty=PathPenalty(
        inequality=jnp.asarray(rng.uniform(0.0, 1.0, (grid.n, 2))),
        equality=jnp.asarray(rng.normal(size=(grid.n, 1))), bounds=jnp.zeros(0),
        rho=jnp.asarray(3.0)))
    z = jnp.asarray(rng.normal(size=tr.n_variables(ocp, grid))).at[-1].set(1.7)
    lam = jnp.asarray(rng.normal(size=tr.equality(z, ocp, grid).size))

    @jax.jit
    def both(z, lam):
        return (tr.equality_jacobian(z, ocp, grid), jax.jacfwd(tr.equality)(z, ocp, grid),
                tr.lagrangian_hessian(z, lam, ocp, grid),
                jax.hessian(tr.lagrangian)(z, lam, ocp, grid))

    A, A_ref, H, H_ref = both(z, lam)
    # both sides are exact derivatives of the same function: equal to round-off
    np.testing.assert_allclose(A, A_ref, atol=1e-13)
    np.testing.assert_allclose(H, H_ref, atol=1e-13)


# Each scheme's costate error against the analytic one (relative to its largest component),
# with the margin for round-off in the O(10^3)-conditioned KKT solve: the single grids of 16
# points converge spectrally (8 points already give ~1e-6 (LG) and ~5e-5 (LGR), 16 reach
# ~1e-13, LGL ~5e-11); the meshes of 3 x 10 points measured 4e-14 (LG), 4e-12 (LGR) and
# 1.8e-7 (LGL): the LGL mesh's joins, from the linkage multipliers, are exact to 4e-15, but
# LGL's interior estimates converge more slowly than Gauss's and Radau's (lgl(10) alone:
# 1.3e-4; 3 x 14 points: 7e-13).
COSTATE_RTOL = {"LGL": 1e-9, "LG": 1e-9, "LGR": 1e-9, "LGL-padded": 1e-9, "LGL-mesh": 1e-6,
                "LG-mesh": 1e-9, "LGR-mesh": 1e-9}


@pytest.mark.parametrize("scheme", list(COSTATE_RTOL))
def test_costates_match_analytic_hcw(hcw_solutions, scheme):
    """Costate estimates (multipliers over quadrature weights; LG: plus the segment's
    quadrature multiplier; on LGL the end points from the transversality conditions, Fahroo &
    Ross 2001's closure, and on an LGL mesh both rows of a join from its linkage multiplier)
    equal the analytic costate at every collocation point, the segments' joins included."""
    ocp, sols = hcw_solutions
    grid, res = sols[scheme]
    assert int(res.status) == Status.SUCCESS
    lam = _live_rows(grid, tr.costates(res.z, res.multipliers, ocp, grid))
    exact = _hcw_analytic_costate(np.asarray(_live_rows(grid, tr.collocation_s(ocp, grid))))
    err = np.max(np.abs(lam - exact)) / np.max(np.abs(exact))
    print(scheme, "costate error", err)
    assert err < COSTATE_RTOL[scheme]


def test_linear_qp_converges_in_one_step(hcw_solutions):
    """The HCW problem is a QP: one Newton step from zero solves it to round-off."""
    _, sols = hcw_solutions
    for grid, res in sols.values():
        assert int(res.status) == Status.SUCCESS and int(res.iterations) == 1
        assert float(res.constraint_residual) < 1e-12


def test_padded_grid_solves_to_the_grid_s_own_solution(hcw_solutions):
    """lgl(16) padded to 21 rows (one program for every grid up to the capacity): the grid's
    own rows solve to the plain lgl(16) solution, and the padding is pinned (X_pad = X_last,
    U_pad = 0, its defect multipliers 0). Both are the same QP's solution by one LU each:
    equal to round-off (the KKT matrix's condition, ~1e3, times 1e-16)."""
    ocp, sols = hcw_solutions
    (grid, padded), (_, plain) = sols["LGL-padded"], sols["LGL"]
    X, U, _ = tr.unpack(padded.z, ocp, grid)
    X0, U0, _ = tr.unpack(plain.z, ocp, lpm.lgl(16))
    rows = grid_rows(16, grid.n)
    np.testing.assert_allclose(X[rows], X0, atol=1e-12 * np.max(np.abs(X0)))
    np.testing.assert_allclose(U[rows], U0, atol=1e-12 * np.max(np.abs(U0)))
    pad = np.setdiff1d(np.arange(grid.n), rows)
    np.testing.assert_allclose(X[pad], np.broadcast_to(X[-1], X[pad].shape), atol=1e-14)
    np.testing.assert_allclose(U[pad], 0.0, atol=1e-14)
    Lam = padded.multipliers[:grid.n * 6].reshape(grid.n, 6)
    np.testing.assert_allclose(Lam[pad], 0.0, atol=1e-12)
    np.testing.assert_allclose(Lam[rows], plain.multipliers[:16 * 6].reshape(16, 6),
                               atol=1e-11 * np.max(np.abs(Lam)))


def test_free_final_time_double_integrator():
    """Free final time by time scaling: the double integrator x'' = u from (1, 0) to rest at
    the origin costs 6/T^3 with energy-optimal control; adding c T makes T* = (18/c)^(1/4).
    With c = 18, T* = 1 and J* = 24. The control is linear in t, so 6 LGR points are exact."""
    def dyn(s, x, u, d, p):
        return jnp.array([x[1], u[0]])

    def bc(x0, xf, sf, p):
        return jnp.concatenate([x0 - jnp.array([1.0, 0.0]), xf])

    def term(x0, xf, sf, p):
        return 18.0 * sf

    ocp = OptimalControlProblem(n_x=2, n_u=1, dynamics=dyn, running_cost=_energy, boundary=bc,
                                s0=jnp.array(0.0), sf=jnp.array(1.5), terminal_cost=term,
                                free_final=True)
    grid = lpm.lgr(6)
    # initial guess: coasting from x = 1 to 0 in 1.5 (a guess with zero velocity and control
    # would leave the defects blind to sf: their sf-derivative is -F/2 = 0)
    t = 0.75 * (tr.state_tau(grid) + 1.0)
    X0 = jnp.stack([1.0 - t / 1.5, jnp.full_like(t, -1.0 / 1.5)], axis=1)
    z0 = tr.pack(X0, jnp.zeros((6, 1)), 1.5, ocp)
    res = quick(lambda z: newton_kkt(ocp, grid, z), z0)
    _, _, sf = tr.unpack(res.z, ocp, grid)
    assert int(res.status) == Status.SUCCESS
    assert abs(float(sf) - 1.0) < 1e-10
    assert abs(float(tr.objective(res.z, ocp, grid)) - 24.0) < 1e-9


def test_bad_input_raises():
    ocp = _hcw_ocp()
    grid = lpm.lgr(4)
    with pytest.raises(ValueError, match="z0 must have shape"):
        newton_kkt(ocp, grid, jnp.zeros(3))
    with pytest.raises(ValueError, match="z0 must be finite"):
        newton_kkt(ocp, grid, jnp.full(tr.n_variables(ocp, grid), jnp.nan))
    with pytest.raises(ValueError, match="multipliers0 must have shape"):
        newton_kkt(ocp, grid, jnp.zeros(tr.n_variables(ocp, grid)), jnp.zeros(2))
    with pytest.raises(ValueError, match="path constraints"):
        newton_kkt(ocp.replace(path=lambda s, x, u, d, p: u), grid,
                   jnp.zeros(tr.n_variables(ocp, grid)))
    with pytest.raises(ValueError, match="free_final"):
        ocp.replace(free_final=True, node_data=jnp.zeros(4)).validate()
    prob = mei2010.problem()
    with pytest.raises(ValueError, match="model must be one of"):
        lpm.solve(prob.replace(model="n-body"), lpm.lgl(9), method="newton")
    with pytest.raises(ValueError, match="method='newton'"):
        lpm.solve(prob.replace(model="two-body"), lpm.lgl(9), method="kkt")
    with pytest.raises(ValueError, match="LGL"):
        lpm.solve(prob, lpm.lg(9), method="kkt")


# ---------------------------------------------------------------- relative transfers

N_SMALL = 17


def _two_body_batch(linear_algebra):
    """mei2010 on the two-body model at e = 0.3 and an invalid e = 1.5, in one vmapped call."""
    prob = mei2010.problem().replace(model="two-body")
    solve = jax.vmap(lambda e: newton_transfer(
        prob.replace(orbit=prob.orbit.replace(e=e)), lpm.lgl(N_SMALL), linear_algebra=linear_algebra))
    return quick(solve, jnp.array([0.3, 1.5]))


@pytest.fixture(scope="module")
def batch_two_body():
    """Newton-KKT with the dense KKT solve."""
    return _two_body_batch("dense")


@pytest.fixture(scope="module")
def batch_two_body_condensed():
    """Newton-KKT with the condensed KKT solve (the default for this problem)."""
    return _two_body_batch("auto")


def test_newton_reproduces_kkt_law_on_linear_model():
    """Same model (Tschauner-Hempel in f), nodes and weights: the Newton-KKT solver from a
    cold start and Mei's KKT law solve the same QP. They use different linear algebra (dense
    LU of the KKT matrix vs null-space QR), so agreement is to round-off amplified by the
    collocation system's condition number (~N^4 ~ 1e5 at N = 16): 1e-9 relative."""
    prob = mei2010.problem()
    grid = lpm.lgl(N_SMALL)
    newton = quick(lambda p: newton_transfer(p, grid, warm_start=False), prob)
    law = lpm.solve(prob, grid, method="kkt")
    assert int(newton.status) == Status.SUCCESS and int(newton.stats["iterations"]) == 1
    scale = np.max(np.abs(law.node_controls))
    np.testing.assert_allclose(newton.node_controls, law.node_controls, atol=1e-9 * scale)
    np.testing.assert_allclose(newton.node_states, law.node_states,
                               atol=1e-9 * np.max(np.abs(law.node_states)))
    assert abs(float(newton.cost) / float(law.cost) - 1.0) < 1e-9


def test_quadratic_convergence(batch_two_body):
    """Newton's residual history on the nonlinear transfer: once the residual is small, each
    step squares it (r_{k+1} <= C r_k^2 with a modest C) down to the tolerance."""
    k = int(batch_two_body.stats["iterations"][0])
    hist = np.asarray(batch_two_body.stats["history"][0, :k + 1])
    print("KKT residual history:", np.array2string(hist, precision=2))
    assert int(batch_two_body.status[0]) == Status.SUCCESS and k >= 2
    assert hist[-1] <= 1e-10
    for r0, r1 in zip(hist[:-1], hist[1:]):
        if r0 < 1e-1 and r1 > 1e-13:        # below 1e-13 round-off, not Newton, sets r1
            assert r1 <= 10.0 * r0**2, (r0, r1)


@pytest.mark.parametrize("which", ["batch_two_body", "batch_two_body_condensed"])
def test_batch_flags_invalid_member(which, request):
    """An e >= 1 member of a vmapped batch reports INVALID_INPUT; every output is finite."""
    batch = request.getfixturevalue(which)
    assert [int(s) for s in batch.status] == [Status.SUCCESS, Status.INVALID_INPUT]
    for leaf in jax.tree_util.tree_leaves(batch):
        assert np.all(np.isfinite(np.asarray(leaf)))


def test_condensed_kkt_solve_reaches_the_dense_kkt_point(batch_two_body,
                                                          batch_two_body_condensed):
    """The condensed KKT solve (null-space system of the eliminated defects) computes the
    dense LU's Newton step for a given (z, lambda); its first multipliers (exact in all but
    the interior position rows, not least squares) and second-order corrections (not
    least-norm) differ, so the iterates do too, but both converge quadratically to the same
    KKT point. The reduced Hessian has the squared condition number of D^2 (~N^4 / h^2), so
    agreement is asserted at 1e-9 of the controls' and multipliers' sizes (observed ~1e-12)."""
    dense = jax.tree_util.tree_map(lambda x: x[0], batch_two_body)
    cond = jax.tree_util.tree_map(lambda x: x[0], batch_two_body_condensed)
    assert int(cond.status) == Status.SUCCESS
    k = int(cond.stats["iterations"])
    assert abs(k - int(dense.stats["iterations"])) <= 1
    hist = np.asarray(cond.stats["history"][:k + 1])
    assert hist[-1] <= 1e-10
    for r0, r1 in zip(hist[:-1], hist[1:]):
        if r0 < 1e-1 and r1 > 1e-13:
            assert r1 <= 10.0 * r0**2, (r0, r1)
    scale = float(np.max(np.abs(dense.node_controls)))
    np.testing.assert_allclose(cond.node_controls, dense.node_controls, atol=1e-9 * scale)
    np.testing.assert_allclose(cond.node_states, dense.node_states,
                               atol=1e-9 * np.max(np.abs(dense.node_states)))
    lam = float(np.max(np.abs(dense.stats["multipliers"])))
    np.testing.assert_allclose(cond.stats["multipliers"], dense.stats["multipliers"], atol=1e-9 * lam)
    assert abs(float(cond.cost) / float(dense.cost) - 1.0) < 1e-12


def test_gradients_match_finite_differences():
    """d cost / d (e, duration, x0, J2) through the KKT point (implicit function theorem) on the
    J2 model, against central differences. Steps balance truncation (O(h^2), third derivative) and the
    solver's round-off (~1e-14 relative / h): e 1e-6, duration 1 s, J2 1e-7, x0 1 m and
    1e-3 m/s; observed agreement is 1e-7 or better, asserted at 1e-5."""
    prob = mei2010.problem().replace(model="j2")
    grid = lpm.lgl(9)

    def cost(e, T, x0, j2):
        p = prob.replace(orbit=prob.orbit.replace(e=e), duration=T, x0=x0, j2=j2)
        return newton_transfer(p, grid).cost

    args = (prob.orbit.e, prob.duration, prob.x0, prob.j2)
    value_and_grad = jax.jit(jax.value_and_grad(cost, argnums=(0, 1, 2, 3))).lower(
        *args).compile(QUICK)                                          # one compile
    _, grads = value_and_grad(*args)

    def central(k, h, index=None):
        def shifted(sign):
            a = list(args)
            a[k] = a[k] + sign * h if index is None else a[k].at[index].add(sign * h)
            return value_and_grad(*a)[0]
        return float((shifted(1.0) - shifted(-1.0)) / (2.0 * h))

    checks = [(grads[0], central(0, 1e-6)), (grads[1], central(1, 1.0)),
              (grads[3], central(3, 1e-7)), (grads[2][0], central(2, 1.0, 0)),
              (grads[2][4], central(2, 1e-3, 4))]
    for analytic, fd in checks:
        assert abs(float(analytic) - fd) <= 1e-5 * abs(fd), (float(analytic), fd)


def test_continuation_rescues_a_failed_start(batch_two_body):
    """With a budget of 2 Newton iterations the direct solve of mei2010 on the two-body model
    (it needs 3) stops at MAX_ITERATIONS; the separation continuation (t = 1/64 of the
    boundary states, where the linear warm start is nearly exact, doubling to 1, each solve
    warm from the last) reaches SUCCESS at the full separation, at the same KKT point as the
    unrestricted solve: both meet tolerance 1e-10 on the same well-conditioned system, so the
    controls agree to ~1e-9 of their size (asserted), the cost closer still."""
    prob = mei2010.problem().replace(model="two-body")
    assert float(prob.orbit.e) == 0.3                   # batch_two_body's first member
    grid = lpm.lgl(N_SMALL)
    short = lpm.NewtonOptions(max_iterations=2)
    no_continuation = lpm.NewtonOptions(max_iterations=2, max_continuation=0)
    direct = quick(lambda p: newton_transfer(p, grid, no_continuation), prob)
    assert int(direct.status) == Status.MAX_ITERATIONS
    continued = quick(lambda p: newton_transfer(p, grid, short), prob)
    assert int(continued.status) == Status.SUCCESS
    assert int(continued.stats["iterations"]) > int(direct.stats["iterations"])    # counts every solve
    ref = jax.tree_util.tree_map(lambda x: x[0], batch_two_body)
    scale = float(np.max(np.abs(ref.node_controls)))
    np.testing.assert_allclose(continued.node_controls, ref.node_controls, atol=1e-9 * scale)
    assert abs(float(continued.cost) / float(ref.cost) - 1.0) < 1e-10


def test_stall_test_ends_a_stuck_solve_and_the_continuation_finishes_it():
    """A dispersed transfer (member 1023 of mei2010.dispersion(PRNGKey(3), 1024): e 0.67, 4.8
    revolutions, a 20 km start) whose direct Newton solve at N = 32 gets stuck: the line search
    accepts only tiny steps along a huge, nearly singular Newton step. The stall test ends it
    as STALLED once the KKT residual has not fallen below 0.9 of its best over
    `stall_iterations` (8) iterations, long before the iteration limit (40); the separation
    continuation (secant predictor from the linear warm start) then converges."""
    from jaxlpm.cases.mei2010 import dispersion
    prob = jax.tree_util.tree_map(lambda x: x[1023],
                                  dispersion(jax.random.PRNGKey(3), 1024, "two-body"))
    grid = lpm.lgl(33)
    opts = lpm.NewtonOptions(max_continuation=0)
    direct = quick(lambda p: newton_transfer(p, grid, opts), prob)
    k = int(direct.stats["iterations"])
    hist = np.asarray(direct.stats["history"][:k + 1])
    assert int(direct.status) == Status.STALLED and k < opts.max_iterations
    w = opts.stall_iterations
    assert k >= w and hist[k] > 0.9 * hist[k - w:k].min()
    assert hist[k] > 1e-6            # stuck far from a solution, not slow near one
    continued = quick(lambda p: newton_transfer(p, grid), prob)
    assert int(continued.status) == Status.SUCCESS
    assert float(continued.stats["constraint_residual"]) <= 1e-10
    assert float(continued.stats["stationarity_residual"]) <= 1e-10


@pytest.mark.parametrize("zero_rows", [slice(0, 6), slice(3, 6), slice(0, 0)])
def test_point_reduced_hessian_skips_only_rows_that_vanish(zero_rows):
    """The condensed solve's T^T H T, which skips the velocity rows where they vanish,
    equals the full contraction for each zero pattern of the point blocks (states linear,
    velocities linear, none), alone and vmapped: the same sums less exact zeros, so to
    round-off (1e-13 of the largest entry)."""
    from jaxlpm.nlp.condensed import point_reduced_hessian
    rng = np.random.default_rng(0)
    blocks = rng.normal(size=(7, 9, 9))
    blocks = blocks + blocks.transpose(0, 2, 1)
    blocks[:, zero_rows, :] = 0.0
    blocks[:, :, zero_rows] = 0.0
    Tp = rng.normal(size=(7, 9, 5))
    full = np.einsum("iak,iab,ibl->kl", Tp, blocks, Tp)
    got = np.asarray(jax.jit(point_reduced_hessian)(jnp.asarray(Tp), jnp.asarray(blocks)))
    np.testing.assert_allclose(got, full, atol=1e-13 * np.max(np.abs(full)))
    # batched with a member that uses every row
    both = np.stack([blocks, rng.normal(size=(7, 9, 9))])
    both[1] = both[1] + both[1].transpose(0, 2, 1)
    got = np.asarray(jax.jit(jax.vmap(point_reduced_hessian, in_axes=(None, 0)))(
        jnp.asarray(Tp), jnp.asarray(both)))
    for member, g in zip(both, got):
        ref = np.einsum("iak,iab,ibl->kl", Tp, member, Tp)
        np.testing.assert_allclose(g, ref, atol=1e-13 * np.max(np.abs(ref)))
