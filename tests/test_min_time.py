"""Augmented-Lagrangian solver, path constraints and minimum-time transfers (issue 4).

Node counts stay modest (compile time dominates; solves compile at backend optimisation
level 0, as in test_newton.py). The minimum-time checks use a transfer whose optimal thrust
direction turns smoothly (the primer |lambda_v| stays above 0.2 of its maximum), where a
global polynomial converges spectrally: K = 16 LG points already give t_f to ~1e-11
relative, so the tolerances below are set by the solver's tolerances, not the mesh. The
paper's own case (duan), whose direction turns within ~50 s, is a mesh study in
`jaxlpm reproduce duan`.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxlpm as lpm
from jaxlpm import Status
from jaxlpm.cases import duan
from jaxlpm.dynamics import hcw_matrix
from jaxlpm.nlp import OptimalControlProblem
from jaxlpm.problems import MinimumTimeTransfer
from jaxlpm.problems.min_time import duration_lower_bound, min_time_ocp, state_scale
from jaxlpm.nlp.transcription import collocated_rows, pack, state_tau, unpack
from jaxlpm.nlp import augmented_lagrangian
from jaxlpm.nlp.augmented_lagrangian import least_squares_start
from jaxlpm.verify import min_time_shooting

# after jaxlpm, which sets one OpenBLAS thread unless scipy has already loaded it (its pool
# contends with XLA's: the dense KKT factorisations of these solves run ~10x slower)
import scipy.integrate  # noqa: E402
import scipy.linalg  # noqa: E402
import scipy.optimize  # noqa: E402

# small grids for speed: solutions that converge unresolved are accepted (conftest)
pytestmark = pytest.mark.usefixtures("loose_accuracy")

QUICK = {"xla_backend_optimization_level": 0}
K = 16


def quick(fn, *args):
    """fn(*args) through jit, compiled at backend optimisation level 0."""
    return jax.jit(fn).lower(*args).compile(QUICK)(*args)


def smooth_problem(thrust=1.0, bounds=(0.0, np.inf)):
    """From rest at the chief to a point 30 m ahead moving at 0.5 m/s: the engine (1 N,
    200 kg) mostly pushes along-track, its direction turns smoothly (t_f ~ 112 s)."""
    orbit = lpm.KeplerOrbit(a=jnp.asarray(duan.A_CHIEF), e=jnp.asarray(0.0))
    xf = jnp.array([5.0, 30.0, -3.0, 0.02, 0.5, 0.01])
    return MinimumTimeTransfer(orbit, jnp.zeros(6), xf, jnp.asarray(thrust),
                               jnp.asarray(200.0), jnp.asarray(bounds))


@pytest.fixture(scope="module")
def solve():
    """One compiled solver (K = 16 LG) for every problem of the same structure."""
    grid = lpm.lg(K)
    return jax.jit(lambda p: lpm.solve(p, grid, throw=False)).lower(
        smooth_problem()).compile(QUICK)


@pytest.fixture(scope="module")
def smooth(solve):
    prob = smooth_problem()
    return prob, solve(prob)


@pytest.fixture(scope="module")
def shoot(smooth):
    """Shooting on the necessary conditions, compiled once for every problem and seed."""
    prob, sol = smooth
    return jax.jit(min_time_shooting).lower(prob, sol.stats["costates_scaled"][0], sol.duration).compile(QUICK)


@pytest.fixture(scope="module")
def shooting(smooth, shoot):
    prob, sol = smooth
    return shoot(prob, sol.stats["costates_scaled"][0], sol.duration)


def test_min_time_converges_with_unit_direction(smooth):
    prob, sol = smooth
    assert int(sol.status) == Status.SUCCESS, sol.message
    # the AL stops at path violation <= 1e-9 (ALOptions.tol_path): |u|^2 - 1 at the nodes
    assert float(sol.stats["path_residual"]) <= 1e-9
    norms = np.linalg.norm(np.asarray(sol.stats["node_directions"]), axis=1)
    np.testing.assert_allclose(norms, 1.0, atol=1e-9)
    assert float(sol.stats["constraint_residual"]) <= 1e-10
    assert float(sol.stats["stationarity_residual"]) <= 1e-8
    # the collocated end states are the requested ones (boundary rows are exact constraints)
    np.testing.assert_allclose(np.asarray(sol.node_states[0]), np.asarray(prob.x0), atol=1e-8)
    np.testing.assert_allclose(np.asarray(sol.node_states[-1]), np.asarray(prob.xf), atol=1e-8)


def test_pontryagin_conditions_at_lg_points(smooth):
    """Costate estimates satisfy the minimum principle: u = -lambda_v / |lambda_v| and the
    Hamiltonian lambda . F = -1 (autonomous, cost s_f - s0) at every LG point."""
    prob, sol = smooth
    lam = np.asarray(sol.stats["costates_scaled"])
    params = min_time_ocp(prob, sol.duration).params
    X = np.asarray(sol.node_states / state_scale(prob))[collocated_rows(lpm.lg(K))]
    U = np.asarray(sol.stats["node_directions"])
    F = X @ np.asarray(hcw_matrix(1.0)).T
    F[:, 3:] += float(params["accel"]) * U
    lv = lam[:, 3:]
    # the direction condition is the stationarity of the discrete Lagrangian in u at each
    # point (exact up to the solver's tolerances); H = -1 holds to the estimates' accuracy,
    # spectral here (K = 16 gives t_f to ~1e-11)
    np.testing.assert_allclose(U, -lv / np.linalg.norm(lv, axis=1, keepdims=True), atol=1e-7)
    np.testing.assert_allclose(np.einsum("ij,ij->i", lam, F), -1.0, atol=1e-6)
    assert np.linalg.norm(lv, axis=1).min() > 0.2 * np.linalg.norm(lv, axis=1).max()


def fly_primer_law(prob, shot):
    """x(t_f) of the shooting solution's law u = -a lambda_v / |lambda_v|, lambda' = -A^T
    lambda, flown from x0 by scipy's DOP853 at rtol 1e-12 (not jaxlpm's integrator)."""
    n = float(prob.orbit.mean_motion)
    A = np.asarray(hcw_matrix(n))
    a = float(prob.acceleration)
    lam_scale = np.asarray(state_scale(prob)) * n        # lambda in SI, per second (any scale)

    def rhs(t, y):
        x, lam = y[:6], y[6:]
        u = -lam[3:] / np.linalg.norm(lam[3:])
        return np.concatenate([A @ x + np.concatenate([np.zeros(3), a * u]), -A.T @ lam])

    lam0 = np.asarray(shot.costate0) / lam_scale
    out = scipy.integrate.solve_ivp(rhs, (0.0, float(shot.duration)),
                                    np.concatenate([np.asarray(prob.x0), lam0]),
                                    method="DOP853", rtol=1e-12, atol=1e-14)
    return out.y[:6, -1]


def test_shooting_confirms_minimum_time(smooth, shooting):
    """An independent method: shooting on the necessary conditions, seeded by the costate
    estimate, converges to the same t_f; its control law flown by scipy's DOP853 hits x_f."""
    prob, sol = smooth
    assert int(shooting.status) == Status.SUCCESS
    # K = 16 resolves this smooth optimum to ~1e-11 relative: 1e-7 s is ~1e-9 relative
    assert abs(float(shooting.duration) - float(sol.duration)) < 1e-7
    xf = fly_primer_law(prob, shooting)
    # DOP853 at rtol 1e-12 over ~100 s of motion at ~30 m: ~1e-9 m; 1e-6 m leaves margin
    np.testing.assert_allclose(xf[:3], np.asarray(prob.xf[:3]), atol=1e-6)
    np.testing.assert_allclose(xf[3:], np.asarray(prob.xf[3:]), atol=1e-8)


def test_flown_renormalised_direction_hits_target(smooth):
    """The interpolated direction, renormalised to the thrust acceleration, flown through the
    CW equations (e = 0 chief) reaches x_f: the interpolation error of a smooth control on
    16 LG points (~1e-6 relative to the 30 m transfer here)."""
    prob, sol = smooth
    t = jnp.linspace(0.0, sol.duration, 7)
    np.testing.assert_allclose(np.linalg.norm(np.asarray(sol.controls(t)), axis=1),
                               float(prob.acceleration), rtol=1e-12)
    flight = lpm.verify.fly(sol, n_save=11)
    assert bool(flight.success)
    miss = np.asarray(flight.terminal_error)
    assert miss[0] < 1e-3 and miss[1] < 1e-5, miss


def test_infeasible_duration_bound_is_reported(smooth, solve):
    """t_max below the minimum time: INFEASIBLE, finite outputs, no hang. At 0.7 t_f it is
    below the proven lower bound too, so no solve runs: zero outputs, the bound in stats."""
    prob, sol = smooth
    t_max = 0.7 * float(sol.duration)
    bad = solve(smooth_problem(bounds=(0.0, t_max)))
    assert int(bad.status) == Status.INFEASIBLE, bad.message
    assert float(bad.stats["duration_lower_bound"]) > t_max
    assert float(bad.duration) == 0.0 and np.all(np.asarray(bad.node_controls) == 0.0)
    assert float(bad.stats["path_residual"]) == 0.0


def test_traced_bad_input_gives_invalid_input(smooth, solve):
    prob, _ = smooth
    bad = solve(prob.replace(thrust=jnp.asarray(-1.0)))        # traced: cannot raise
    assert int(bad.status) == Status.INVALID_INPUT
    assert float(bad.duration) == 0.0
    assert np.all(np.asarray(bad.node_controls) == 0.0)


def test_vmap_over_thrust(smooth):
    prob, sol = smooth
    thrusts = jnp.array([1.0, 1.3])
    grid = lpm.lg(K)
    batch = quick(jax.vmap(lambda T: lpm.solve(prob.replace(thrust=T), grid, throw=False)),
                  thrusts)
    assert list(np.asarray(batch.status)) == [Status.SUCCESS, Status.SUCCESS]
    # same problem, same iterations: the batched member equals the single solve to round-off
    assert abs(float(batch.duration[0]) - float(sol.duration)) < 1e-9
    assert float(batch.duration[1]) < float(sol.duration)       # more thrust, less time


def test_duration_gradient_matches_finite_differences(smooth, solve):
    """d t_f / d thrust by implicit differentiation at the KKT point vs central differences
    (h = 1e-4 N: truncation ~h^2 t_f''' ~ 1e-8, solver noise ~1e-11 s / h ~ 1e-7 relative)."""
    prob, _ = smooth
    grid = lpm.lg(K)

    def tf(T):
        return lpm.solve(prob.replace(thrust=T), grid, throw=False).duration

    g = float(quick(jax.grad(tf), jnp.asarray(1.0)))
    h = 1e-4
    fd = (float(solve(prob.replace(thrust=jnp.asarray(1.0 + h))).duration)
          - float(solve(prob.replace(thrust=jnp.asarray(1.0 - h))).duration)) / (2 * h)
    assert g < 0.0
    np.testing.assert_allclose(g, fd, rtol=1e-5)


def test_bad_input_raises():
    prob = smooth_problem()
    grid = lpm.lg(K)
    cases = [
        # the augmented Lagrangian solves the linear and two-body models; J2 takes "condensed"
        (prob.replace(model="j2"), grid, "'two-body' models"),
        (prob.replace(thrust=jnp.asarray(0.0)), grid, "thrust must be positive"),
        (prob.replace(mass=jnp.asarray(-1.0)), grid, "mass must be positive"),
        (prob.replace(xf=prob.x0), grid, "different from x0"),
        (prob.replace(x0=prob.x0.at[0].set(jnp.nan)), grid, "x0"),
        (prob.replace(duration_bounds=jnp.array([100.0, 50.0])), grid, "t_min < t_max"),
        (prob, lpm.lg(2), "at least 3"),
        (prob, "lg(16)", "Grid"),
    ]
    for p, g, match in cases:
        with pytest.raises(ValueError, match=match):
            lpm.solve(p, g)


# ------------------------------------------- thrust levels and duration bounds (issue 17)

K_LOW = 64          # LG points for the 0.01 N transfer: its 5 orbits need several per orbit


@pytest.fixture(scope="module")
def solve_low():
    """One compiled solver on K_LOW LG points."""
    grid = lpm.lg(K_LOW)
    return jax.jit(lambda p: lpm.solve(p, grid, throw=False)).lower(
        smooth_problem()).compile(QUICK)


@pytest.fixture(scope="module")
def low_thrust(solve_low):
    prob = smooth_problem(thrust=0.01)
    return prob, solve_low(prob)


def test_thrust_levels_converge_on_a_resolving_grid(smooth, solve_low, low_thrust):
    """No t_max: 1 N (112 s) and 0.01 N (5 orbits) both end SUCCESS on 64 LG points, unit
    directions and the requested ends. At 1 N both grids resolve the smooth transfer (~1e-11
    relative): they agree to the AL's tolerances (|u|^2 - 1 <= 1e-9: ~1e-9 relative in t_f,
    1e-7 s; 1e-6 s leaves margin)."""
    prob, sol = smooth
    fast = solve_low(prob)
    assert int(fast.status) == Status.SUCCESS, fast.message
    assert abs(float(fast.duration) - float(sol.duration)) < 1e-6
    prob, low = low_thrust
    assert int(low.status) == Status.SUCCESS, low.message
    # converged, but 64 LG points do not resolve 5 orbits (t_f is 1.8 s off, see below): at
    # the default tolerance this solution is INACCURATE (this module accepts it, conftest)
    assert bool(lpm.solution.accuracy.inaccurate(low.stats, lpm.DEFAULT_TOLERANCE))
    assert float(low.stats["path_residual"]) <= 1e-9
    np.testing.assert_allclose(np.linalg.norm(np.asarray(low.stats["node_directions"]), axis=1), 1.0,
                               atol=1e-9)
    np.testing.assert_allclose(np.asarray(low.node_states[-1]), np.asarray(prob.xf), atol=1e-8)


def test_low_thrust_minimum_time_confirmed_by_shooting(low_thrust, shoot):
    """0.01 N: shooting on Pontryagin's conditions (grid-independent), seeded by the K = 64
    costates, converges to the continuous t_f*, whose law flown by scipy's DOP853 for the 5
    orbits hits x_f. The direction turns within a fraction of an orbit, so LG converges
    algebraically here: t_f - t_f* is 20, 1.8 and 0.04 s at K = 32, 64, 96 (6e-5 relative at
    64); 2e-4 leaves margin. The lower bound holds below t_f*."""
    prob, sol = low_thrust
    shot = shoot(prob, sol.stats["costates_scaled"][0], sol.duration)
    assert int(shot.status) == Status.SUCCESS
    t_star = float(shot.duration)
    assert abs(float(sol.duration) - t_star) < 2e-4 * t_star
    assert float(duration_lower_bound(prob)) < t_star
    xf = fly_primer_law(prob, shot)
    # DOP853 at rtol 1e-12 over 5 orbits of motion at ~1 km: ~1e-8 m; 1e-5 m leaves margin
    np.testing.assert_allclose(xf[:3], np.asarray(prob.xf[:3]), atol=1e-5)
    np.testing.assert_allclose(xf[3:], np.asarray(prob.xf[3:]), atol=1e-8)


def test_unresolved_low_thrust_is_not_reported_infeasible(solve):
    """No t_max, 16 LG points: 0.01, 1e-3 and 1e-4 N last 5, >= 18 and >= 180 orbits (the
    lower bound), which 16 points cannot represent; every such request is feasible (bounded
    thrust reaches any HCW state), so the AL's stall ends STALLED, never INFEASIBLE, with
    finite outputs."""
    for thrust in (1e-2, 1e-3, 1e-4):
        sol = solve(smooth_problem(thrust=thrust))
        assert int(sol.status) == Status.STALLED, (thrust, sol.message)
        assert np.isfinite(float(sol.duration))
        assert np.all(np.isfinite(np.asarray(sol.node_controls)))


def test_too_short_duration_bound_is_infeasible(smooth, solve):
    """1 mN with t_max = 0.9 t_lb: shown infeasible by the lower bound, though t_max is 19
    times the rest-to-rest bang-bang time 2 sqrt(|dr| / a). 1 N with t_max between t_lb and
    t_f: shown by the AL's certificate with the bound active."""
    slow = smooth_problem(thrust=1e-3)
    t_lb = float(duration_lower_bound(slow))
    a = float(slow.acceleration)
    assert 0.9 * t_lb > 10.0 * 2.0 * np.sqrt(float(jnp.linalg.norm(slow.xf[:3])) / a)
    bad = solve(slow.replace(duration_bounds=jnp.array([0.0, 0.9 * t_lb])))
    assert int(bad.status) == Status.INFEASIBLE, bad.message
    prob, sol = smooth
    t_lb = float(duration_lower_bound(prob))
    assert 0.9 * float(sol.duration) < t_lb < float(sol.duration)
    t_max = 0.5 * (t_lb + float(sol.duration))
    bad = solve(prob.replace(duration_bounds=jnp.array([0.0, t_max])))
    assert int(bad.status) == Status.INFEASIBLE, bad.message
    assert float(bad.stats["path_multipliers"].bounds[1]) > 0.0


def test_lower_bound_holds_on_flown_arcs(smooth):
    """Any arc flown at full thrust is a feasible transfer between its end states, so
    `duration_lower_bound` of those states is at most the arc's duration: checked on CW
    flights (scipy DOP853, rtol 1e-12) with a turning direction, and with the thrust
    along-track, where the bound is exact (n x_c / 2 grows at a, sigma stays)."""
    prob, _ = smooth
    n, a = float(prob.orbit.mean_motion), float(prob.acceleration)
    A = np.asarray(hcw_matrix(n))
    ts = np.linspace(0.0, 300.0, 31)

    def arc_bounds(direction):
        def rhs(t, x):
            return A @ x + np.concatenate([np.zeros(3), a * direction(t)])
        out = scipy.integrate.solve_ivp(rhs, (0.0, ts[-1]), np.asarray(prob.xf), t_eval=ts,
                                        method="DOP853", rtol=1e-12, atol=1e-12)
        bound = [float(duration_lower_bound(prob.replace(x0=jnp.asarray(out.y[:, 0]),
                                                         xf=jnp.asarray(out.y[:, k]))))
                 for k in range(1, ts.size)]
        return np.array(bound), ts[1:]

    w = 2 * np.pi / 100.0
    bound, dt = arc_bounds(lambda t: np.array([np.cos(w * t), 0.6 * np.sin(w * t),
                                               0.8 * np.sin(w * t)]))
    assert np.all(bound <= dt * (1.0 + 1e-9))         # 1e-9: the integrator's accuracy
    bound, dt = arc_bounds(lambda t: np.array([0.0, 1.0, 0.0]))
    np.testing.assert_allclose(bound, dt, rtol=1e-9)


# --------------------------------------------------------- a generic inequality problem


def _double_integrator(s, x, u, d, p):
    return jnp.array([x[1], u[0]])


def _energy(s, x, u, d, p):
    return 0.5 * u[0] ** 2


def _rest_to_rest(x0, xf, sf, p):
    return jnp.concatenate([x0, xf - jnp.array([1.0, 0.0])])


def _bound(s, x, u, d, p):
    return jnp.concatenate([u - p["umax"], -u - p["umax"]])


def _saturated_cost(umax, T=1.0, d=1.0):
    """Exact optimum of min 1/2 int u^2, x'' = u, rest to rest over d in T, |u| <= umax:
    u = sat(k (1 - 2 t / T)) (the costate is linear in t), k from x(T) = d."""
    def u(t, k):
        return np.clip(k * (1.0 - 2.0 * t / T), -umax, umax)

    def reach(k):
        return scipy.integrate.quad(lambda t: (T - t) * u(t, k), 0.0, T, limit=200,
                                    points=[T / 2 * (1 - umax / k), T / 2 * (1 + umax / k)])[0]

    k = scipy.optimize.brentq(lambda k: reach(k) - d, umax * 1.0001, 1e3)
    return 0.5 * scipy.integrate.quad(lambda t: u(t, k) ** 2, 0.0, T, limit=200)[0]


def test_augmented_lagrangian_bounded_control_matches_exact_optimum():
    """Energy-optimal double integrator with |u| <= 5 (the unconstrained peak is 6; below 4
    nothing is feasible, the bang-bang minimum time being 2 sqrt(d / umax) = T at 4): the AL
    solution saturates, meets the bound and its cost matches the exact optimum. The control's
    kinks (entering and leaving the bound) limit a global polynomial to algebraic
    convergence, so the check is 1e-5 relative rather than round-off (the error measured at
    24 LGR points is 6e-7)."""
    umax = 5.0
    grid = lpm.lgr(24)
    ocp = OptimalControlProblem(n_x=2, n_u=1, dynamics=_double_integrator,
                                running_cost=_energy, boundary=_rest_to_rest,
                                s0=jnp.asarray(0.0), sf=jnp.asarray(1.0),
                                params={"umax": jnp.asarray(umax)}, path=_bound)
    z0 = pack(jnp.zeros((state_tau(grid).shape[0], 2)), jnp.zeros((grid.n, 1)), ocp.sf, ocp)
    res = quick(lambda o, z: augmented_lagrangian(o, grid, z), ocp, z0)
    assert int(res.status) == Status.SUCCESS
    _, U, _ = unpack(res.z, ocp, grid)
    assert float(jnp.max(jnp.abs(U))) <= umax + 1e-9
    assert float(jnp.max(jnp.abs(U))) > umax - 1e-6            # the bound is active
    assert float(res.complementarity) <= 1e-9
    mu = np.asarray(res.path_multipliers.inequality)
    assert np.all(mu >= 0.0) and mu.max() > 0.0
    cost = float(jnp.dot(grid.weights, 0.5 * U[:, 0] ** 2) * 0.5)
    exact = _saturated_cost(umax)
    np.testing.assert_allclose(cost, exact, rtol=1e-5)
    assert exact > 6.0        # the unconstrained optimum, 1/2 int (6 (1 - 2t))^2 = 6


def _planar_double_integrator(s, x, u, d, p):
    return jnp.concatenate([x[2:], u])


def _no_cost(s, x, u, d, p):
    return 0.0 * s


def _elapsed_time(x0, xf, sf, p):
    return sf


def _from_rest_to_a_point(x0, xf, sf, p):
    return jnp.concatenate([x0, xf[:2] - jnp.array([1.0, 0.5])])


def _unit_control(s, x, u, d, p):
    return jnp.dot(u, u)[None] - 1.0


def test_least_squares_start_recovers_the_multipliers_at_the_solution():
    """`least_squares_start` at a KKT point returns its multipliers, those of the path
    equality with them. Minimum time from rest to a point at distance d with a unit
    acceleration, final velocity free: u is constant along the line, t_f = sqrt(2 d) (exact on
    any grid: the states are quadratic in t), and nu = -lambda_v . u / 2 is not zero at any
    LGR point (lambda_v falls linearly to 0 at t_f, which LGR leaves out). At a solution
    stationary to ~1e-10 (the inner Newton's tolerance) the least-squares system, of full row
    rank here, gives the solver's multipliers to ~1e-8."""
    grid = lpm.lgr(8)
    ocp = OptimalControlProblem(n_x=4, n_u=2, dynamics=_planar_double_integrator,
                                running_cost=_no_cost, boundary=_from_rest_to_a_point,
                                s0=jnp.asarray(0.0), sf=jnp.asarray(1.0), params={},
                                terminal_cost=_elapsed_time, free_final=True,
                                path_equality=_unit_control)
    rows = state_tau(grid).shape[0]
    z0 = pack(jnp.zeros((rows, 4)), jnp.tile(jnp.array([0.6, 0.8]), (grid.n, 1)), 1.0, ocp)
    res = quick(lambda o, z: augmented_lagrangian(o, grid, z), ocp, z0)
    assert int(res.status) == Status.SUCCESS
    np.testing.assert_allclose(float(res.z[-1]), np.sqrt(2.0 * np.hypot(1.0, 0.5)), rtol=1e-9)
    lam, penalty = quick(lambda o, z: least_squares_start(o, grid, z, 10.0), ocp, res.z)
    nu = np.asarray(penalty.equality)
    np.testing.assert_allclose(nu, np.asarray(res.path_multipliers.equality), rtol=1e-6,
                               atol=1e-9)
    assert np.min(np.abs(nu)) > 1e-4       # weighted, and falling with lambda_v towards t_f
    np.testing.assert_allclose(np.asarray(lam), np.asarray(res.multipliers), rtol=1e-6,
                               atol=1e-8)
    assert float(penalty.rho) == 10.0 and penalty.inequality.size == 0


def test_newton_refuses_path_constraints():
    grid = lpm.lgr(6)
    ocp = OptimalControlProblem(n_x=2, n_u=1, dynamics=_double_integrator,
                                running_cost=_energy, boundary=_rest_to_rest,
                                s0=jnp.asarray(0.0), sf=jnp.asarray(1.0),
                                params={"umax": jnp.asarray(5.0)}, path=_bound)
    z0 = pack(jnp.zeros((state_tau(grid).shape[0], 2)), jnp.zeros((grid.n, 1)), ocp.sf, ocp)
    with pytest.raises(ValueError, match="augmented_lagrangian"):
        lpm.nlp.newton_kkt(ocp, grid, z0)


# ------------------------------------------------------------------ the duan case's data


def test_duan_frames_and_fly_around_conditions():
    """The paper's frame <-> LVLH map is an involution; the target state has no along-track
    drift and a fly-around ellipse centred on the chief (coasting one period returns to it,
    and the mean position over the period is the origin)."""
    n = duan.mean_motion()
    v = np.arange(1.0, 7.0)
    np.testing.assert_array_equal(duan.lvlh_to_paper(duan.paper_to_lvlh(v)), v)
    xf = duan.paper_to_lvlh(duan.final_state_paper())
    np.testing.assert_array_equal(xf[:3], [600.0, 1000.0, 500.0])       # (y_D, x_D, -z_D)
    assert abs(float(duan.drift_rate(xf))) < 1e-15
    ts, xs = duan.coast(xf, n, days=2 * np.pi / n / 86400.0, n_save=2001)
    np.testing.assert_allclose(xs[-1], xf, atol=1e-8)                  # periodic
    np.testing.assert_allclose(xs[:-1, :3].mean(axis=0), 0.0, atol=1e-6)   # centred
    x0 = duan.paper_to_lvlh(duan.initial_state_paper())
    np.testing.assert_array_equal(x0, [2.0, 2.0, -2.0, 0.01, 0.01, -0.01])
    # the 20-day coast of the paper's Fig. 4 (closed-form flow; a Pade matrix exponential of
    # A t returned NaN there) against scipy's expm at its end, from a drifting state: both
    # exact flows, so they agree to the rounding of ||A t|| ~ 2e3 (1e-6 m on km states)
    drifting = xf + np.array([0.0, 0.0, 0.0, 0.01, 0.0, 0.0])
    ts, xs = duan.coast(drifting, n, n_save=3)
    ref = scipy.linalg.expm(np.asarray(hcw_matrix(n)) * ts[-1]) @ drifting
    assert np.all(np.isfinite(xs))
    np.testing.assert_allclose(xs[-1], ref, atol=1e-6)


def test_default_solve_refines_to_an_accurate_transfer():
    """The issue-19 acceptance for this family (at the library's default tolerance, not this
    module's loose one): 0.05 N lasts 1.2 orbits; 2 LGR segments of 16 points converge but
    do not resolve it (INACCURATE), `solve(problem)` climbs the mesh ladder to a SUCCESS whose
    control, flown by an independent integrator, stays within the tolerance of the plan; on
    both meshes the estimate and the flown distance agree within 3x (the check flight is a
    collocation of the flown IVP on 2.4 check points per collocation point)."""
    tol = lpm.DEFAULT_TOLERANCE
    prob = smooth_problem(thrust=0.05)
    coarse = lpm.solve(prob, lpm.lgr_mesh(2, 16), tolerance=tol, throw=False)
    assert int(coarse.status) == Status.INACCURATE, coarse.message
    refined = lpm.solve(prob, tolerance=tol)          # raises unless SUCCESS
    assert int(refined.stats["rung"]) >= 1
    # the finer mesh's minimum time lies within the coarse one's estimated accuracy
    assert abs(float(refined.duration) - float(coarse.duration)) < 1e-3 * float(coarse.duration)
    for sol in (coarse, refined):
        plan = np.asarray(lpm.verify.fly(sol).plan_error)
        est = np.array([float(sol.stats["error_position"]), float(sol.stats["error_velocity"])])
        assert np.all(plan <= 3.0 * est) and np.all(est <= 3.0 * plan), (plan, est)
    plan = np.asarray(lpm.verify.fly(refined).plan_error)
    assert plan[0] < tol.position and plan[1] < tol.velocity
