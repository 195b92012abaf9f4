"""The Mei 2010 laws: optimality against independent computations, gradients, batching,
input validation and singular problems."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.integrate import solve_ivp

jax.config.update("jax_enable_x64", True)

from jaxlpm import (EnergyOptimalTransfer, KeplerOrbit, SolveError, Status, lg, lgl,  # noqa: E402
                    solve)
from jaxlpm.dynamics import elliptic_lvlh_matrix  # noqa: E402

# small grids for speed: solutions that converge unresolved are accepted (conftest)
pytestmark = pytest.mark.usefixtures("loose_accuracy")

X0 = jnp.array([10000.0, 10000.0, 500.0, 4.0, -23.485, 0.3])   # Mei's case plus out-of-plane
N_TEST = 32                                                      # modest: compile time dominates


def make_problem(e=0.3, revolutions=1.0, **kw):
    orbit = KeplerOrbit(a=jnp.asarray(9500e3), e=jnp.asarray(e), f0=jnp.asarray(0.2))
    return EnergyOptimalTransfer.from_revolutions(orbit, X0, jnp.zeros(6), revolutions, **kw)


def time_domain_gramian_cost(prob):
    """Independent optimum 1/2 d^T W^-1 d of 1/2 int |u|^2 dt on the linearised elliptic LVLH
    model in TIME (no STM, no true anomaly, no collocation): Psi' = -Psi A, W' = Psi B B^T Psi^T."""
    o = prob.orbit
    e, k2, p, mu = float(o.e), float(o.k2), float(o.p), float(o.mu)
    B = np.vstack([np.zeros((3, 3)), np.eye(3)])

    def rhs(t, y):
        f = y[0]
        rho = 1 + e * np.cos(f)
        A = np.asarray(elliptic_lvlh_matrix(p / rho, k2 * rho**2, -2 * k2**2 * rho**3 * e * np.sin(f), mu))
        Psi = y[1:37].reshape(6, 6)
        return np.concatenate([[k2 * rho**2], (-Psi @ A).ravel(), (Psi @ B @ B.T @ Psi.T).ravel()])

    y0 = np.concatenate([[float(o.f0)], np.eye(6).ravel(), np.zeros(36)])
    T = float(prob.duration)
    y = solve_ivp(rhs, (0, T), y0, method="DOP853", rtol=1e-12, atol=1e-14).y[:, -1]
    Psi, W = y[1:37].reshape(6, 6), y[37:].reshape(6, 6)
    d = Psi @ np.asarray(prob.xf) - np.asarray(prob.x0)
    return 0.5 * d @ np.linalg.solve(W, d)


@pytest.mark.parametrize("law", ["stm", "kkt"])
def test_optimum_matches_time_domain_gramian(law):
    prob = make_problem()
    sol = solve(prob, lgl(N_TEST + 1), method=law)
    assert int(sol.status) == Status.SUCCESS
    ref = time_domain_gramian_cost(prob)
    # One revolution at e = 0.3 is resolved spectrally by N = 32 (the Mei case's 3 revolutions
    # need N ~ 64); 1e-6 is far above the integrator's 1e-12 and far below any modelling error.
    assert abs(float(sol.cost) - ref) / ref < 1e-6
    # cost_true_anomaly is Mei's eq. (8): k^2 times the time-domain energy, exactly.
    assert float(sol.stats["cost_true_anomaly"]) == pytest.approx(float(prob.orbit.k2) * float(sol.cost),
                                                         rel=1e-14)


def test_laws_converge_to_each_other():
    """Both laws are spectral discretisations of the same problem: their nodal controls, states
    and costate estimates must approach each other quickly as N grows."""
    prob = make_problem()

    def gaps(N):
        grid = lgl(N + 1)
        s, k = solve(prob, grid, method="stm"), solve(prob, grid, method="kkt")
        rel = lambda a, b, sl=slice(None): float(jnp.max(jnp.abs(a - b)[sl]) / jnp.max(jnp.abs(a)))
        # costates compared at interior nodes: LGL end-point costate estimates are less accurate
        return (s, k), (rel(s.node_controls, k.node_controls), rel(s.node_states, k.node_states),
                        rel(s.stats["costates_th"], k.stats["costates_th"], slice(1, -1)))

    _, coarse = gaps(N_TEST)
    (s, k), fine = gaps(N_TEST + 16)
    for c, f in zip(coarse, fine):
        assert f < 0.1 * c            # spectral convergence: a decade or more per 16 nodes here
    assert max(fine) < 1e-5
    # Boundary conditions hold exactly in both laws (up to rounding of 1e4 m states).
    for sol in (s, k):
        np.testing.assert_allclose(sol.node_states[0], prob.x0, atol=1e-8)
        np.testing.assert_allclose(sol.node_states[-1], prob.xf, atol=1e-7)


def test_interpolation_reproduces_nodes():
    sol = solve(make_problem(), lgl(N_TEST + 1), method="kkt")
    t = sol.times[7]
    # Time -> true anomaly -> tau round trip is exact to ~1e-15; values at a node are exact.
    np.testing.assert_allclose(sol.controls(t), sol.node_controls[7], rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(sol.states(t), sol.node_states[7], rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("law", ["stm", "kkt"])
def test_gradients_match_finite_differences(law):
    base = make_problem()

    def cost(e, duration):
        prob = base.replace(orbit=base.orbit.replace(e=e), duration=duration)
        return solve(prob, lgl(N_TEST + 1), method=law).cost

    e0, T0 = 0.3, float(base.duration)
    g_e, g_T = jax.jit(jax.grad(cost, argnums=(0, 1)))(e0, T0)
    f = jax.jit(cost)
    # Central differences: truncation ~ (h/scale)^2 relative, rounding ~ eps J / (h J').
    # J varies with e on a scale of 0.1 and with duration on the orbital time scale
    # 1/n ~ 1.5e3 s, so these steps keep both errors below 1e-8 and 1e-6 checks the derivative.
    he, hT = 1e-5, 0.1
    fd_e = (f(e0 + he, T0) - f(e0 - he, T0)) / (2 * he)
    fd_T = (f(e0, T0 + hT) - f(e0, T0 - hT)) / (2 * hT)
    assert float(g_e) == pytest.approx(float(fd_e), rel=1e-6)
    assert float(g_T) == pytest.approx(float(fd_T), rel=1e-6)


@pytest.mark.parametrize("law", ["stm", "kkt"])
def test_vmap_over_eccentricity_equals_loop_without_recompiling(law):
    traces = []

    def counted(prob, grid):
        traces.append(1)
        return solve(prob, grid, method=law)

    jitted = jax.jit(counted)
    base, grid = make_problem(), lgl(N_TEST + 1)
    es = jnp.linspace(0.0, 0.6, 16)
    loop = [float(jitted(base.replace(orbit=base.orbit.replace(e=e)), grid).cost) for e in es]
    assert len(traces) == 1                      # a new e value reuses the compiled function
    batched = jax.vmap(lambda e: jitted(base.replace(orbit=base.orbit.replace(e=e)), grid).cost)(es)
    assert np.all(np.asarray(batched) > 0)
    # Identical arithmetic batched or not, up to XLA's batched kernels reassociating sums: the
    # round-off of a cost near its minimum over e scales with the batch's largest cost, not
    # with its own (one member at 3e-3 differed by 5e-15 against costs up to 0.6).
    np.testing.assert_allclose(np.asarray(batched), loop, rtol=1e-12, atol=1e-12 * max(loop))


@pytest.mark.parametrize("law", ["stm", "kkt"])
def test_traced_invalid_input_gives_status_not_nan(law):
    base, grid = make_problem(), lgl(N_TEST + 1)
    es = jnp.array([0.3, 1.2, -0.1, 0.5])
    sols = jax.vmap(lambda e: solve(base.replace(orbit=base.orbit.replace(e=e)), grid,
                                    method=law))(es)
    assert [int(s) for s in sols.status] == [0, Status.INVALID_INPUT, Status.INVALID_INPUT, 0]
    for leaf in jax.tree_util.tree_leaves(sols):
        assert np.all(np.isfinite(np.asarray(leaf)))
    assert float(sols.cost[1]) == 0.0 and float(sols.cost[0]) > 0.0


@pytest.mark.parametrize("law", ["stm", "kkt"])
def test_singular_problems_report_status(law):
    grid = lgl(N_TEST + 1)
    radial_only = make_problem(thrust_axes=(True, False, True))
    # Radial thrust alone cannot change y~' + 2 x~ (a first integral of the TH equations).
    with pytest.raises(SolveError, match="SINGULAR") as raised:
        solve(radial_only, grid, method=law)
    assert raised.value.status == Status.SINGULAR
    sol = solve(radial_only, grid, method=law, throw=False)
    assert int(sol.status) == Status.SINGULAR
    for leaf in jax.tree_util.tree_leaves(sol):
        assert np.all(np.isfinite(np.asarray(leaf)))       # no silent garbage either
    # A zero-length transfer under jit cannot raise: it is reported as invalid input.
    zero = jax.jit(lambda p: solve(p, grid, method=law))(
        make_problem().replace(duration=jnp.asarray(0.0)))
    assert int(zero.status) == Status.INVALID_INPUT


def test_removed_channel_that_stays_controllable():
    grid = lgl(N_TEST + 1)
    prob = make_problem(thrust_axes=(False, True, True))    # along-track + normal only
    s, k = solve(prob, grid, method="stm"), solve(prob, grid, method="kkt")
    assert int(s.status) == int(k.status) == Status.SUCCESS
    assert float(jnp.max(jnp.abs(k.node_controls[:, 0]))) == 0.0
    assert float(jnp.max(jnp.abs(s.node_controls[:, 0]))) == 0.0
    # Without radial thrust the transfer costs more than with it.
    assert float(k.cost) > float(solve(make_problem(), grid, method="kkt").cost)
    # Same discretisation-level agreement as with all channels (see test_laws_agree_at_nodes).
    assert float(s.cost) == pytest.approx(float(k.cost), rel=1e-6)
    # The multipliers come from an overdetermined least-squares solve through D^T (entries
    # ~N^2 = 1e3 here): its residual is round-off relative to the multipliers' size (measured
    # 1.3e-9 of max|gamma| at N = 32; 1e-6 absolute was within 4 % of the measured value).
    assert float(k.stats["stationarity_residual"]) < 1e-8 * float(
        jnp.max(jnp.abs(k.stats["multipliers"])))


@pytest.mark.parametrize("law", ["stm", "kkt"])
def test_padded_grid_gives_the_grid_s_own_solution_from_one_program(law):
    """A concrete solve runs the law on lgl(n) padded to 129 points (`jaxlpm.collocation.
    padded`): one program for every n <= 129, and the solution equals the law on lgl(n) itself
    (traced: no padding). Padding adds exact zeros to the sums and puts the grid's own rows of
    the KKT law's QR factorisations first, so the two differ by round-off alone. Measured
    (2026-12-06, both laws, the four grids below): cost 4e-13 relative, nodal states 1.3e-11
    of max |x|, controls and costates 1.7e-8 of their largest at 129 points (KKT law; 9e-12 at
    33), the position estimate (a distance between two ~1e4 m states) by 2e-10 of max |x|.
    The bounds are 8x to 50x those."""
    from jaxlpm import compilation
    from jaxlpm.collocation.padded import MIN_CAPACITY, grid_rows, pad_grid

    direct = jax.jit(lambda p, g: solve(p, g, method=law, throw=False), static_argnums=1)
    before = len(compilation.events)
    for e, n in [(0.0, 5), (0.3, 17), (0.6, 33), (0.3, MIN_CAPACITY)]:
        prob, grid = make_problem(e=e), lgl(n)
        ref, sol = direct(prob, grid), solve(prob, grid, method=law, throw=False)
        assert sol.grid == grid and sol.times.shape == (n,)
        assert int(sol.status) == int(ref.status)
        assert float(sol.cost) == pytest.approx(float(ref.cost), rel=1e-11)
        scale = float(jnp.max(jnp.abs(ref.node_states)))
        np.testing.assert_allclose(sol.node_states, ref.node_states, rtol=0, atol=1e-10 * scale)
        # the controls and costates are second derivatives of the nodal positions (D^2 Q,
        # D^T through the multipliers): their round-off is eps N^4 relative
        roundoff = 1e-15 * n**4
        np.testing.assert_allclose(sol.node_controls, ref.node_controls, rtol=0,
                                   atol=roundoff * float(jnp.max(jnp.abs(ref.node_controls))))
        lam, lam_ref = sol.trajectory.node_costates, ref.trajectory.node_costates
        np.testing.assert_allclose(lam, lam_ref, rtol=0,
                                   atol=roundoff * float(jnp.max(jnp.abs(lam_ref))))
        for key in ("error_position", "relative_error"):
            assert abs(float(sol.stats[key]) - float(ref.stats[key])) <= 1e-8 * (
                scale if key == "error_position" else 1.0)
    # one program of the law served the four grids (compiled, or loaded from the cache)
    after = [e for e in compilation.events[before:] if e["name"].endswith(f"{law}_law")]
    assert len(after) <= 1
    # the padded layout: the grid's first n - 1 points, padding at tau = 1, its last point
    pg = pad_grid(9)
    assert pg.n == MIN_CAPACITY and int(pg.live) == 9
    np.testing.assert_array_equal(pg.points[grid_rows(9, pg.n)], lgl(9).points)
    assert np.all(pg.weights[8:-1] == 0) and np.all(pg.D[8:-1] == 0) and np.all(pg.D[:, 8:-1] == 0)


@pytest.mark.parametrize(
    "change, match",
    [
        (dict(e=1.0), "orbit.e"),
        (dict(e=-0.1), "orbit.e"),
        (dict(a=-1.0), "orbit.a"),
        (dict(duration=0.0), "duration"),
        (dict(duration=-5.0), "duration"),
        (dict(x0=jnp.array([np.nan, 0, 0, 0, 0, 0.0])), "x0"),
        (dict(xf=jnp.zeros(5)), "xf"),
        (dict(thrust_axes=(True, True)), "thrust_axes"),
    ],
)
def test_bad_input_raises(change, match):
    prob = make_problem()
    orbit_keys = {k: v for k, v in change.items() if k in ("e", "a")}
    other = {k: v for k, v in change.items() if k not in ("e", "a")}
    prob = prob.replace(orbit=prob.orbit.replace(**orbit_keys), **other)
    with pytest.raises(ValueError, match=match):
        solve(prob, lgl(N_TEST + 1), method="kkt")


def test_bad_grid_method_and_float32():
    prob = make_problem()
    with pytest.raises(ValueError, match="at least 4 LGL points"):
        solve(prob, lgl(3), method="stm")
    with pytest.raises(ValueError, match="LGL"):
        solve(prob, lg(10), method="kkt")
    with pytest.raises(ValueError, match="method"):
        solve(prob, lgl(9), method="shooting")
    jax.config.update("jax_enable_x64", False)
    try:
        with pytest.raises(ValueError, match="float64"):
            solve(prob, lgl(9), method="kkt")
    finally:
        jax.config.update("jax_enable_x64", True)


def test_import_sets_the_cpu_scheduler_workaround():
    """Without it, jit(vmap(kkt_law)) can deadlock in jaxlib 0.10's batched QR (BENCHMARKS.md);
    the vmap tests above would hang rather than fail."""
    import os

    from jaxlpm import _cpu_runtime

    assert _cpu_runtime.SCHEDULER_FLAG in os.environ.get("XLA_FLAGS", "")
