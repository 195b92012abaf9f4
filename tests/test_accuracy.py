"""SUCCESS means an accurate transfer (issue 19): the error estimate between the nodes, the
INACCURATE status, the multi-segment LGR mesh and adaptive mesh refinement.

The estimate (`jaxlpm.nlp.accuracy`: the GPOPS-II defect estimate and the flight of the
solution's control on a check mesh of 2.4 points per collocation point) is checked against what
`jaxlpm.verify.fly` measures with an independent integrator (diffrax Dopri8, rtol 1e-12)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxlpm as lpm
from jaxlpm import Status
from jaxlpm.solution.accuracy import refinement_error
from jaxlpm.solvers.refine import split_breaks

X0 = jnp.array([10e3, 10e3, 0.0, 4.0, -3.0, 0.0])


def orbit(e):
    """Perigee 600 km altitude (the robustness dispersion's chief)."""
    return lpm.KeplerOrbit(a=6978e3 / (1.0 - e), e=e, i=0.5, raan=0.5, argp=0.2, f0=0.3)


def transfer(e, revolutions, model="linear"):
    return lpm.EnergyOptimalTransfer.from_revolutions(orbit(e), X0, jnp.zeros(6), revolutions,
                                                      model=model)


# ---- the multi-segment mesh ----------------------------------------------------------------

def test_lgr_mesh_operators_are_exact_on_piecewise_polynomials():
    """Each segment of lgr_mesh(k, n) holds a degree-n state polynomial: D differentiates
    it exactly, the weights integrate degree 2n - 2 exactly, interpolation reproduces it."""
    mesh = lpm.lgr_mesh(3, 6, [-1.0, -0.3, 0.4, 1.0])
    x = mesh.support
    p = lambda t: 1.0 + t - 2 * t**3 + 0.5 * t**6             # noqa: E731  degree n = 6
    dp = lambda t: 1.0 - 6 * t**2 + 3 * t**5                   # noqa: E731
    np.testing.assert_allclose(mesh.D @ p(x), dp(mesh.points), atol=1e-11)
    # int_{-1}^{1} t^10 dt = 2 / 11 (degree 2n - 2 = 10)
    assert float(mesh.weights @ mesh.points**10) == pytest.approx(2.0 / 11.0, rel=1e-13)
    for t in (-1.0, -0.31, 0.0, 0.4, 0.77, 1.0):
        assert float(mesh.interpolate_state(p(x), t)) == pytest.approx(float(p(t)), abs=1e-12)
    with pytest.raises(ValueError, match="strictly increasing"):
        lpm.lgr_mesh(2, 6, [-1.0, 1.0, 0.0])


@pytest.mark.parametrize("scheme, degree, exact", [("LG", 6, 11), ("LGL", 5, 9)])
def test_lg_and_lgl_mesh_operators_are_exact_on_piecewise_polynomials(scheme, degree, exact):
    """lg_mesh(k, n): each segment's polynomial on its start break and n Gauss points (degree
    n), Gauss weights exact to degree 2n - 1, and the quadrature rows E X = W X' (each
    segment's end break from its start and the quadrature of the derivative); lgl_mesh(k, n):
    degree n - 1 on the segment's n points (its breaks twice), weights exact to 2n - 3, the
    linkage rows L X = 0 for a continuous function."""
    mesh = lpm.make_mesh(scheme, 3, 6, [-1.0, -0.3, 0.4, 1.0])
    x = mesh.state_tau
    coefficients = 1.0 / (1.0 + np.arange(degree + 1))
    p = np.polynomial.Polynomial(coefficients)
    np.testing.assert_allclose(mesh.D @ p(x), p.deriv()(mesh.points), atol=1e-11)
    t = mesh.points
    assert float(mesh.weights @ t**exact) == pytest.approx(
        (1.0 - (-1.0) ** (exact + 1)) / (exact + 1), abs=1e-13)
    for tau in (-1.0, -0.31, 0.0, 0.4, 0.77, 1.0):
        assert float(mesh.interpolate_state(p(x), tau)) == pytest.approx(float(p(tau)),
                                                                         abs=1e-12)
    if scheme == "LG":
        E, W = mesh.quadrature
        np.testing.assert_allclose(E @ p(x), W @ p.deriv()(t), atol=1e-12)
        assert mesh.n_rows == 3 * 7 + 1 and mesh.linkage is None
    else:
        np.testing.assert_allclose(mesh.linkage @ p(x), 0.0, atol=1e-14)
        assert mesh.n_rows == 3 * 6 and mesh.quadrature is None


def test_split_breaks_puts_the_pieces_where_the_error_is():
    b = split_breaks([-1.0, 0.0, 1.0], [1e-12, 1e-4], 8)
    assert b.size == 9 and b[0] == -1.0 and b[-1] == 1.0 and np.all(np.diff(b) > 0)
    assert np.sum(b < 0.0) == 1            # the resolved segment keeps one piece


def test_refinement_error_splits_where_a_constraint_fails_between_the_nodes():
    """A segment whose dense check exceeds the tolerance kappa times weighs e_max kappa^4
    (it gets kappa times the pieces of the least accurate segment); one within it keeps its
    own error."""
    tol = lpm.Tolerance(position=0.1, velocity=1e-4, path=1e-4)
    stats = dict(segment_error=jnp.array([1e-6, 1e-9, 1e-9, 1e-9]),
                 segment_violation=jnp.array([[0.0, 0.0, 0.0], [0.05, 0.0, 0.0],
                                              [0.0, 3e-4, 0.0], [0.2, 0.0, 5e-4]]))
    w = np.asarray(refinement_error(stats, tol))
    np.testing.assert_allclose(w, [1e-6, 1e-9, 1e-6 * 3.0 ** 4, 1e-6 * 5.0 ** 4], rtol=1e-12)
    b = split_breaks([-1.0, -0.5, 0.0, 0.5, 1.0], w, 12)
    pieces = np.histogram(b[:-1], bins=[-1.0, -0.5, 0.0, 0.5, 1.0])[0]
    assert pieces[1] == 1 and pieces[3] > pieces[2] > pieces[0]
    # without safety constraints the weight is the relative error itself
    assert refinement_error({"segment_error": stats["segment_error"]}, tol) is \
        stats["segment_error"]


# ---- the estimate against the flown miss -------------------------------------------------

ESTIMATE_GRIDS = {"lgl17": lpm.lgl(17), "mesh4x12": lpm.lgr_mesh(4, 12)}
ESTIMATE_SET = [(e, rev) for e in (0.0, 0.3, 0.6) for rev in (1.0, 3.0)]


@pytest.mark.parametrize("grid", list(ESTIMATE_GRIDS))
def test_estimate_bounds_the_flown_miss(grid):
    """Over e in {0, 0.3, 0.6} and 1 or 3 revolutions on grids from unresolved to resolved:
    the flown terminal miss is at most 3x the estimate (plus the integrator's floor, 1e-6 m
    and 1e-9 m/s: rtol 1e-12 on 10 km states), and the estimate (the largest distance of the
    state polynomial from the flight of its control) bounds that distance as the independent
    flight measures it (`Flight.plan_error`) within 10x."""
    problems = [transfer(e, rev) for e, rev in ESTIMATE_SET]
    batch = jax.tree.map(lambda *xs: jnp.stack(xs), *problems)
    solve = jax.jit(jax.vmap(lambda p: lpm.solve(p, ESTIMATE_GRIDS[grid], method="newton",
                                                 throw=False)))
    sol = solve(batch)
    assert np.all(np.isin(np.asarray(sol.status), [Status.SUCCESS, Status.INACCURATE]))
    flight = lpm.verify.fly(sol)
    miss, plan = np.asarray(flight.terminal_error), np.asarray(flight.plan_error)
    est = np.stack([np.asarray(sol.stats["error_position"]),
                    np.asarray(sol.stats["error_velocity"])], axis=1)
    floor = np.array([1e-6, 1e-9])
    # the flight's plan error compares 401 interpolated states: its floor is ~1e-5 m
    plan_floor = np.array([1e-4, 1e-7])
    print(grid, np.c_[est, miss, plan])
    assert np.all(miss <= 3.0 * est + floor), np.c_[est, miss]
    # the estimate also bounds the path deviation the flight measures; where the grid is coarse
    # the check mesh (2.4 points per node) is coarse too, so it may exceed it (2 mm against
    # 2e-5 m at lgl(17) over 3 circular revolutions: pessimistic, never optimistic here)
    assert np.all(plan <= 10.0 * est + plan_floor), np.c_[est, plan]
    # and the status follows the default tolerance
    tol = lpm.DEFAULT_TOLERANCE
    accurate = (est[:, 0] <= tol.position) & (est[:, 1] <= tol.velocity)
    np.testing.assert_array_equal(np.asarray(sol.status) == Status.SUCCESS, accurate)


def test_estimate_on_the_two_body_model():
    """The same bound on the exact two-body model (the nonlinear check flight)."""
    sol = lpm.solve(transfer(0.6, 3.0, "two-body"), lpm.lgl(33), method="newton", throw=False)
    assert int(sol.status) == Status.INACCURATE
    flight = lpm.verify.fly(sol)
    miss, plan = np.asarray(flight.terminal_error), np.asarray(flight.plan_error)
    est = np.array([sol.stats["error_position"], sol.stats["error_velocity"]])
    assert np.all(miss <= 3.0 * est) and np.all(est <= 3.0 * plan), (est, miss, plan)


@pytest.mark.parametrize("e, grid", [(0.0, "lgl33"), (0.6, "mesh4x12")])
def test_linear_flight_by_the_transition_matrix(e, grid):
    """The linear model's check flight by the variation of constants with Yamanaka &
    Ankersen's transition matrix (`separable_flight`, 3 revolutions) against the collocation
    flight of the same control (`check_flight`: one Newton step on each 12-point piece) and
    scipy's DOP853 (rtol 1e-13) on the same interpolated control: it is as far from scipy as
    a hundredth of the estimate, plus 1e-9 of the largest state (the interior rows carry the
    piece's integration matrix's error, order 12 in its length: 2e-9 of 13 units for the
    circular transfer, whose estimate is 1e-11), and it gives the collocation flight's
    estimate within that."""
    from scipy.integrate import solve_ivp

    from jaxlpm.nlp.accuracy import check_flight, check_mesh, separable_flight
    from jaxlpm.problems.energy_optimal import scaled_rows, transfer_ocp, ya_kernel
    mesh = {"lgl33": lpm.lgl(33), "mesh4x12": lpm.lgr_mesh(4, 12)}[grid]
    problem = transfer(e, 3.0)
    X, U = scaled_rows(lpm.solve(problem, mesh, method="newton", throw=False))
    check = check_mesh(mesh)
    ocp, _, _ = transfer_ocp(problem, check)
    collocated = np.asarray(check_flight(ocp, check, mesh, X, U, newton_steps=1))
    separable = np.asarray(separable_flight(ocp, check, mesh, X, U, ya_kernel(problem.orbit)))

    s0, sf = float(ocp.s0), float(ocp.sf)
    rates = jax.jit(lambda s, x: ocp.dynamics(
        s, x, mesh.interpolate_control(U, 2.0 * (s - s0) / (sf - s0) - 1.0), None, ocp.params))
    rows = np.concatenate([np.asarray(check.points).reshape(check.n_segments, -1)[:, 1:],
                           np.asarray(check.breaks)[1:, None]], axis=1)
    scipy_flight = solve_ivp(
        lambda s, x: np.asarray(rates(s, x)),
        (s0, sf), np.asarray(X[0]), method="DOP853", rtol=1e-13, atol=1e-13,
        t_eval=s0 + 0.5 * (sf - s0) * (rows.reshape(-1) + 1.0)).y.T.reshape(separable.shape)
    polynomial = np.asarray(jax.vmap(lambda t: mesh.interpolate_state(X, t))(
        jnp.asarray(rows.reshape(-1)))).reshape(separable.shape)
    estimate = np.abs(collocated - polynomial).max()
    floor = 1e-9 * np.abs(scipy_flight).max()
    assert np.abs(separable - scipy_flight).max() <= 0.01 * estimate + floor
    assert abs(np.abs(separable - polynomial).max() - estimate) <= 0.01 * estimate + floor


# ---- INACCURATE, and refinement by default -------------------------------------------------

@pytest.fixture(scope="module")
def eccentric():
    """e = 0.6, 3 revolutions: lgl(17) misses by ~300 km when flown."""
    return transfer(0.6, 3.0)


def test_coarse_fixed_grid_is_inaccurate(eccentric):
    for method in ("kkt", "newton"):
        sol = lpm.solve(eccentric, lpm.lgl(17), method=method, throw=False)
        assert int(sol.status) == Status.INACCURATE, (method, sol.message)
        assert "error estimate" in sol.message
        with pytest.raises(lpm.SolveError) as err:
            lpm.solve(eccentric, lpm.lgl(17), method=method)
        assert err.value.status == Status.INACCURATE
    # a looser tolerance accepts it; under jit the status comes out the same way
    loose = lpm.Tolerance(position=1e7, velocity=1e4)
    assert bool(lpm.solve(eccentric, lpm.lgl(17), tolerance=loose).success)
    status = jax.jit(lambda p: lpm.solve(p, lpm.lgl(17), throw=False).status)(eccentric)
    assert int(status) == Status.INACCURATE


def test_default_solve_refines_to_the_tolerance(eccentric):
    """The default ladder climbs past its first rung (4 x 16 is INACCURATE here) and ends on
    one of its rungs' shapes, SUCCESS and flown within the default tolerance's goal. (Its
    second rung raises the degree, 4 x 32, keeping the breaks; the split of the breaks where
    the error is, end to end, is tests/test_meshes.py's.)"""
    sol = lpm.solve(eccentric)
    assert bool(sol.success), sol.message
    rung = int(sol.stats["rung"])
    assert isinstance(sol.grid, lpm.LGRMesh) and rung >= 1
    assert (sol.grid.n_segments, sol.grid.segment.n) == lpm.DEFAULT_LADDER.rungs[rung]
    tol = lpm.DEFAULT_TOLERANCE
    assert float(sol.stats["error_position"]) <= tol.position
    miss = np.asarray(lpm.verify.fly(sol).terminal_error)
    # the default tolerance's promise: a flown miss within 1 m and 1 mm/s
    assert miss[0] < 1.0 and miss[1] < 1e-3, miss


def test_batched_refinement_matches_the_single_solve_with_gradients():
    """`refine_batch`: the member that needs it climbs (e = 0.3, 3 revolutions: one rung)
    while the circular one stops at the first rung; the climbing member ends on the mesh and
    cost of `solve(problem)` (the same ladder, splits and warm starts, member by member), and
    its implicit gradients, taken on that final mesh, equal central differences of the cost
    on it (duration: h = 0.1 s, e: h = 1e-6, where the differences' truncation, h^2 / 6
    times the third derivative, and the cost's convergence noise over h are both below 1e-7
    of the derivative; measured 5e-9 for the duration). Its dJ/dx0 is the costate at t = 0."""
    from jaxlpm.batch.refine import refine_batch
    climbing = transfer(0.3, 3.0)
    batch = jax.tree_util.tree_map(lambda *x: jnp.stack(x), climbing, transfer(0.0, 1.0))
    out = refine_batch(batch, gradients=True)
    assert np.all(out["status"] == Status.SUCCESS)
    assert out["rung"][0] >= 1 and out["rung"][1] == 0
    single = lpm.solve(climbing)
    assert int(single.stats["rung"]) == out["rung"][0]
    assert abs(out["cost"][0] - float(single.cost)) <= 1e-10 * float(single.cost)
    np.testing.assert_allclose(out["dcost_dx0"][0], single.costates(0.0), rtol=1e-6,
                               atol=1e-12)

    def cost(problem):
        return float(lpm.solve(problem, single.grid, method="newton").cost)

    for name, h, shift in (
            ("duration", 0.1, lambda p, d: p.replace(duration=p.duration + d)),
            ("orbit.e", 1e-6, lambda p, d: p.replace(orbit=p.orbit.replace(e=p.orbit.e + d)))):
        fd = (cost(shift(climbing, h)) - cost(shift(climbing, -h))) / (2.0 * h)
        assert abs(out[f"dcost_d{name}"][0] - fd) <= 1e-7 * abs(fd), (name, fd)


def test_tolerance_is_checked():
    with pytest.raises(ValueError, match="position"):
        lpm.Tolerance(position=-1.0)
    with pytest.raises(ValueError, match="Tolerance"):
        lpm.solve(transfer(0.0, 1.0), lpm.lgl(17), tolerance=0.1)


# ---- minimum time --------------------------------------------------------------------------

def test_minimum_time_coarse_grid_is_inaccurate():
    """The minimum-time transfer of tests/test_api.py: lg(16) resolves it (flown 1e-8 m),
    lg(4) does not."""
    problem = lpm.MinimumTimeTransfer(lpm.KeplerOrbit(a=6878137.0, e=0.0), jnp.zeros(6),
                                      jnp.array([5.0, 30.0, -3.0, 0.02, 0.5, 0.01]), 1.0,
                                      200.0)
    fine = lpm.solve(problem, lpm.lg(16))
    assert float(fine.stats["error_position"]) < 1e-3
    coarse = lpm.solve(problem, lpm.lg(4), throw=False)
    miss = np.asarray(lpm.verify.fly(coarse).terminal_error)
    est = np.array([coarse.stats["error_position"], coarse.stats["error_velocity"]])
    assert int(coarse.status) == Status.INACCURATE
    assert np.all(miss <= 3.0 * est + np.array([1e-6, 1e-9])), (est, miss)
