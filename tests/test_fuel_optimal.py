"""Fuel-optimal transfers by the energy-to-fuel homotopy on segmented LGR meshes (issue 5).

The reference is independent of the collocation: a linear program on a fine time grid with
zero-order-hold thrust, the HCW flow discretised exactly by the matrix exponential (scipy), and
the 2-norm of the in-plane thrust inner-approximated by a polygon of M directions. The along-
track transfers stay in the orbit plane (z0 = zf = 0 and z decouples, so any z thrust only adds
fuel), so the LP is planar.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import scipy.sparse as sp
from scipy.linalg import expm
from scipy.optimize import linprog

from jaxlpm import (DEFAULT_TOLERANCE, EnergyOptimalTransfer, KeplerOrbit, Status, lgl, solve,
                    verify)
from jaxlpm.collocation.segments import (aligned_breaks, segmented_lgr, segmented_mesh,
                                         uniform_breaks)
from jaxlpm.constants import R_EARTH
from jaxlpm.linalg import dense_solve
from jaxlpm.dynamics import hcw_flow, hcw_matrix
from jaxlpm.problems.fuel_optimal import FuelOptimalTransfer, condensed_mesh
from jaxlpm.solvers.fuel_optimal import (burn_arcs, indirect_fuel_optimal, primer,
                                         refine_fuel_optimal)
from jaxlpm.nlp.homotopy import HomotopyOptions, pointwise_control, throttle

A_CHIEF = R_EARTH + 400e3
ORBIT = KeplerOrbit(a=jnp.asarray(A_CHIEF), e=jnp.asarray(0.0))
PERIOD = float(ORBIT.period)
N_MEAN = float(ORBIT.mean_motion)
TARGETS = (4000.0, 8000.0, -4000.0)
SEGMENTS, POINTS = 24, 8


def problem(y, thrust=0.3, duration=PERIOD):
    return FuelOptimalTransfer(ORBIT, jnp.zeros(6), jnp.array([0.0, y, 0.0, 0.0, 0.0, 0.0]),
                               jnp.asarray(duration), jnp.asarray(thrust), jnp.asarray(50.0),
                               jnp.asarray(1000.0))


def hcw_input_matrices():
    """(A, B) of HCW in s = n t, accelerations in L n^2."""
    return hcw_matrix(1.0), jnp.concatenate([jnp.zeros((3, 3)), jnp.eye(3)])


def batch(problems):
    return jax.tree_util.tree_map(lambda *xs: jnp.stack(xs), *problems)


def member(tree, i):
    return jax.tree_util.tree_map(lambda x: x[i], tree)


@pytest.fixture(scope="module")
def final():
    return refine_fuel_optimal(batch([problem(y) for y in TARGETS]), SEGMENTS, POINTS)


def lp_delta_v(dy, steps=500, directions=512, umax=0.3 / 50.0):
    """min sum |u_k| dt (ZOH on `steps` intervals, u_k = sum_j a_kj d_j, a >= 0, sum_j a_kj <=
    umax, d_j the unit vectors at angles 2 pi j / M) to (0, dy) at rest in one period.
    The polygon is an inner approximation: the LP value is at most 1 / cos(pi / M) above the
    ZOH problem's, which is itself above the continuous optimum by the ZOH restriction."""
    n = N_MEAN
    A = np.array([[0, 0, 1, 0], [0, 0, 0, 1], [3 * n * n, 0, 0, 2 * n], [0, 0, -2 * n, 0]])
    B = np.vstack([np.zeros((2, 2)), np.eye(2)])
    dt = PERIOD / steps
    aug = np.zeros((6, 6))
    aug[:4, :4], aug[:4, 4:] = A * dt, B * dt
    flow = expm(aug)
    gamma, P = np.zeros((steps, 4, 2)), np.eye(4)
    for k in range(steps - 1, -1, -1):       # Gamma_k = Phi(T - t_{k+1}) int_0^dt Phi B
        gamma[k] = P @ flow[:4, 4:]
        P = P @ flow[:4, :4]
    th = 2.0 * np.pi * np.arange(directions) / directions
    D = np.stack([np.cos(th), np.sin(th)])
    A_eq = np.einsum("kab,bj->akj", gamma, D).reshape(4, -1)
    A_ub = sp.kron(sp.eye(steps), np.ones((1, directions))).tocsr()
    res = linprog(np.full(steps * directions, dt), A_ub=A_ub, b_ub=np.full(steps, umax),
                  A_eq=A_eq, b_eq=np.array([0.0, dy, 0.0, 0.0]), bounds=(0, None),
                  method="highs")
    assert res.status == 0, res.message
    return res.fun


def test_all_members_converge(final):
    assert np.all(np.asarray(final.status) == Status.SUCCESS)
    assert np.all(np.asarray(final.stats["eps"]) <= 1e-6)
    # the refinement stopped because the fuel settled at the 1e-4 level (the rule)
    assert np.all(final.stats["fuel_change"] < 1e-4) and np.all(final.stats["passes"] >= 2)
    # collocated final state vs target: Newton's tolerance 1e-11 in units of L = |rf| (4-8
    # km) is < 1e-7 m; allow 1e-6 m and 1e-9 m/s for the elimination's round-off
    err = np.asarray(final.stats["terminal_error"])
    assert np.all(err[:, 0] < 1e-6) and np.all(err[:, 1] < 1e-9)


def test_vmapped_passes_agree_with_member_by_member(final):
    """`refine_fuel_optimal` in one vmapped group (width 3) gives the member-by-member
    solutions (width 1, the default): the same homotopy per member, a vmapped member frozen
    once done. Fuel to 1e-9 relative and multipliers to 1e-9 of their largest: round-off of
    a different evaluation order, amplified by the homotopy's Newton solves at eps = 1e-6
    (their residual tolerance is 1e-11 of the unit; measured 8e-11 and 1.5e-13)."""
    grouped = refine_fuel_optimal(batch([problem(y) for y in TARGETS]), SEGMENTS, POINTS,
                                  width=3)
    np.testing.assert_array_equal(grouped.status, final.status)
    np.testing.assert_array_equal(grouped.stats["passes"], final.stats["passes"])
    np.testing.assert_allclose(grouped.stats["fuel"], final.stats["fuel"], rtol=1e-9)
    np.testing.assert_allclose(grouped.stats["multipliers"], final.stats["multipliers"],
                               rtol=0, atol=1e-9 * np.max(np.abs(final.stats["multipliers"])))
    with pytest.raises(ValueError, match="width must be a positive integer"):
        refine_fuel_optimal(batch([problem(y) for y in TARGETS]), SEGMENTS, POINTS, width=0)


def test_fuel_matches_fine_grid_lp(final):
    """The issue's acceptance: fuel within 0.1 % of an independent method. The LP's own error
    is <= 1 - cos(pi / 512) = 1.9e-5 (polygon) plus the ZOH restriction (5554 s / 500 steps;
    measured < 1e-5 by halving the step), so 1e-4 is asserted: ten times tighter than asked."""
    dv = np.asarray(final.delta_v)
    for i, y in enumerate(TARGETS[:2]):
        ref = lp_delta_v(y)
        assert abs(dv[i] - ref) / ref < 1e-4, (y, dv[i], ref)


def test_indirect_agrees_with_direct(final):
    """Shooting on the costates with the smoothed law (exact HCW flow, Gauss quadrature on
    panels aligned with the direct mesh), started from the LGR energy-optimal costates."""
    for i, y in enumerate(TARGETS):
        sol = member(final, i)
        # the mesh's breaks (an LGRMesh in tau) as fractions of the transfer
        b = aligned_breaks(0.0, 1.0, 200, 0.5 * (np.asarray(sol.grid.breaks)[1:-1] + 1.0))
        ind = indirect_fuel_optimal(problem(y), b, sol.stats["energy_multipliers"])
        assert int(ind.status) == Status.SUCCESS
        assert abs(float(ind.dv) - float(sol.delta_v)) / float(sol.delta_v) < 1e-4
        assert float(ind.terminal_error[0]) < 1e-6


def test_paper_claims(final):
    fuel = np.asarray(final.stats["fuel"])
    # +-4 km: the dynamics are linear and x0 = 0, so (x, u) -> (-x, -u) maps one transfer
    # onto the other: equal fuel to round-off
    assert abs(fuel[0] - fuel[2]) / fuel[0] < 1e-9
    # 8 km vs 4 km: exactly 2 in the impulsive limit; finite burns (80 s vs 40 s at 0.3 N)
    # lose a little more on the longer burns, so slightly above 2
    assert 2.0 < fuel[1] / fuel[0] < 2.01
    # the paper's largest fuel, 4.89 g (given to 3 digits)
    assert abs(1e3 * fuel[1] - 4.89) < 0.005
    # the energy-optimal solution burns more
    assert np.all(np.asarray(final.stats["energy_fuel"]) > 1.5 * fuel)


def test_necessary_conditions(final):
    """Switching structure from the costates: full thrust along p where |p| > 1 + eps, none
    where |p| < 1 - eps; the LGR costate estimates equal the exact adjoint flow from nu."""
    for i in range(len(TARGETS)):
        sol = member(final, i)
        p = np.asarray(sol.stats["node_primers"]).reshape(-1, 3)
        S = np.linalg.norm(p, axis=1)
        w = np.asarray(sol.stats["node_throttle"]).reshape(-1)
        eps = float(sol.stats["eps"])
        assert np.all(w[S > 1 + eps] > 1 - 1e-12) and np.all(w[S < 1 - eps] < 1e-12)
        u = np.asarray(sol.node_controls).reshape(-1, 3)
        on = w > 1e-3
        cosang = np.sum(u[on] * p[on], 1) / (np.linalg.norm(u[on], axis=1) * S[on])
        assert np.all(cosang > 1 - 1e-12)
        t = np.asarray(sol.times).reshape(-1)
        exact = np.stack([np.asarray(primer(sol, tk)) for tk in t[::7]])
        # both are the same linear map of nu up to the collocation error of Phi (spectral on
        # these segments): 1e-9 leaves room for the 1e-13 measured
        assert np.max(np.abs(exact - p[::7])) < 1e-9
        arcs = burn_arcs(sol)
        assert len(arcs) == 2 and arcs[0][0] == 0.0 and arcs[1][1] == pytest.approx(PERIOD)


def test_energy_limit_matches_energy_optimal_solver(final):
    """eps = 1 with the bound inactive is the energy-optimal transfer: 1/2 int |u|^2 dt equals
    the package's KKT law on 65 LGL nodes (an independent transcription, spectrally converged:
    1e-7 relative is far above both errors)."""
    sol = member(final, 0)
    assert float(jnp.max(jnp.linalg.norm(sol.stats["energy_node_controls"], axis=-1))) < 0.3 / 50.0
    ref = solve(EnergyOptimalTransfer(ORBIT, jnp.zeros(6), problem(4000.0).xf,
                                      jnp.asarray(PERIOD)), lgl(65), method="kkt")
    assert abs(float(sol.stats["energy_cost"]) - float(ref.cost)) / float(ref.cost) < 1e-7


@pytest.mark.parametrize("scheme", ["LGR", "LG"])
def test_condensed_transcription_is_spectrally_accurate(scheme):
    """Constant thrust: the condensed LGR (LG) final state equals the exact flow (matrix
    exponential of the augmented system) to round-off on a 6-segment, 8-point mesh (the
    state is a degree-8 polynomial on each piece there: the exponential's truncation on
    pieces of length <= 1.5 is below 1e-10)."""
    A, B = hcw_input_matrices()
    mesh = segmented_mesh(np.array([0.0, 0.4, 1.1, 2.0, 3.5, 5.0, 2 * np.pi]), 8, scheme)
    cond = condensed_mesh(A, B, mesh)
    x0, u = jnp.array([0.3, -0.2, 0.1, 0.05, 0.0, -0.1]), jnp.array([0.01, -0.02, 0.005])
    U = jnp.broadcast_to(u, (mesh.n_segments, mesh.grid.n, 3))
    X = cond.states(x0, U)
    aug = jnp.zeros((9, 9)).at[:6, :6].set(A).at[:6, 6:].set(B)
    exact = (jax.scipy.linalg.expm(aug * 2 * np.pi) @ jnp.concatenate([x0, u]))[:6]
    assert float(jnp.max(jnp.abs(X[-1, -1] - exact))) < 1e-10
    via_E = cond.Phi @ x0 + jnp.einsum("kiab,kib->a", cond.E, U)
    assert float(jnp.max(jnp.abs(via_E - X[-1, -1]))) < 1e-13
    # continuity: each segment starts at the previous one's end state
    assert float(jnp.max(jnp.abs(X[1:, 0] - X[:-1, -1]))) == 0.0


def test_throttle_law():
    eps = 0.1
    assert float(throttle(0.5, eps)) == 0.0 and float(throttle(1.5, eps)) == 1.0
    assert float(throttle(1.0, eps)) == pytest.approx(0.5)
    # eps = 1 is the energy law u / u_max = p / 2, smooth through p = 0
    p = jnp.array([0.3, -0.4, 0.1])
    assert np.allclose(pointwise_control(p, 1.0), p / 2)
    assert np.allclose(pointwise_control(jnp.zeros(3), 1.0), 0.0)
    assert np.all(np.isfinite(jax.jacfwd(pointwise_control)(jnp.zeros(3), 1.0)))


def test_stalled_homotopy_says_so():
    """eps_min far below what Newton can resolve on this mesh: STALLED with the eps reached."""
    opts = HomotopyOptions(eps_min=1e-14, min_step=0.05, max_steps=60)
    sol = solve(problem(4000.0), segmented_lgr(uniform_breaks(0.0, 1.0, SEGMENTS), POINTS),
                options=opts, throw=False)
    assert int(sol.status) in (Status.STALLED, Status.MAX_ITERATIONS)
    assert float(sol.stats["eps"]) > 1e-14 and np.isfinite(float(sol.stats["fuel"]))
    if int(sol.status) == Status.STALLED:
        assert "stalled" in sol.message


def test_infeasible_thrust_and_invalid_member():
    """A thrust too weak for the transfer (0.002 N: at most ~0.2 m/s in a period, 0.96 m/s
    needed) is INFEASIBLE, with full thrust everywhere and its miss reported; a traced invalid
    member gives INVALID_INPUT and zeros; the others are unaffected."""
    mesh = segmented_lgr(uniform_breaks(0.0, 1.0, SEGMENTS), POINTS)
    probs = batch([problem(4000.0), problem(8000.0, thrust=0.002), problem(4000.0, thrust=-1.0)])
    sols = jax.vmap(lambda p: solve(p, mesh))(probs)
    status = np.asarray(sols.status)
    # converged (the uniform mesh does not resolve the switches to the default tolerance:
    # INACCURATE is a converged solution too)
    assert status[0] in (Status.SUCCESS, Status.INACCURATE)
    assert status[1] == Status.INFEASIBLE and float(sols.stats["terminal_error"][1, 0]) > 1e3
    assert status[2] == Status.INVALID_INPUT and float(sols.stats["fuel"][2]) == 0.0
    assert np.all(np.isfinite(np.asarray(sols.node_states)))


def test_a_failed_step_after_a_converged_one_is_not_infeasible():
    """A transfer of the fuel dispersion (experiments/fuel_refine_dispersion.py, member 36:
    e = 0.046, 1.49 periods, 0.173 N on 50 kg) whose homotopy converged at eps = 1 with the
    engine at no more than 37 % of its thrust had ended INFEASIBLE when a later step's dual
    ascent ran away. The feasible set does not depend on eps, so a failure after a converged
    step is a smaller step: the homotopy now reaches its last eps and the collocated final
    state meets the target (the condensed problem's own residual, 1e-6 m: round-off of the
    final-state equations in the solver's units)."""
    orbit = KeplerOrbit(a=jnp.asarray(A_CHIEF), e=jnp.asarray(0.0464))
    prob = FuelOptimalTransfer(orbit, jnp.zeros(6), jnp.array([308.0, -3578.0, -11.0, 0, 0, 0]),
                               jnp.asarray(8677.0), jnp.asarray(0.173), jnp.asarray(50.0),
                               jnp.asarray(1000.0))
    sol = solve(prob, segmented_lgr(uniform_breaks(0.0, 1.0, SEGMENTS), POINTS), throw=False)
    assert int(sol.status) in (Status.SUCCESS, Status.INACCURATE), sol.message
    assert float(sol.stats["eps"]) == pytest.approx(HomotopyOptions().eps_min)
    assert float(sol.stats["terminal_error"][0]) < 1e-6


def test_bad_input_raises():
    mesh = segmented_lgr(uniform_breaks(0.0, 1.0, 4), 4)
    with pytest.raises(ValueError, match="model must be one of"):
        solve(problem(4000.0).replace(model="hcw"), mesh)
    with pytest.raises(ValueError, match="perigee"):
        solve(problem(4000.0).replace(orbit=ORBIT.replace(e=jnp.asarray(0.1)), model="j2"),
              mesh)
    with pytest.raises(ValueError, match="thrust_max must be positive"):
        solve(problem(4000.0, thrust=0.0), mesh)
    with pytest.raises(ValueError, match="from 0 to 1"):
        solve(problem(4000.0), segmented_lgr(np.linspace(0.0, 2.0, 5), 4))
    with pytest.raises(ValueError, match="at least 3 LGR points"):
        solve(problem(4000.0), segmented_lgr(uniform_breaks(0.0, 1.0, 4), 2))
    with pytest.raises(ValueError, match="strictly increasing"):
        segmented_lgr(np.array([0.0, 0.5, 0.5, 1.0]), 4)
    with pytest.raises(ValueError, match="need at least"):
        aligned_breaks(0.0, 1.0, 2, [0.2, 0.5, 0.7])


def test_closed_form_flow_and_dense_solve():
    """The closed-form HCW flow equals the matrix exponential; the LAPACK-free elimination
    equals LAPACK's solve (a random 48 x 48 system: condition ~1e3, so 1e-11)."""
    A, _ = hcw_input_matrices()
    for tau in (0.3, 2.0, 7.5):
        assert float(jnp.max(jnp.abs(hcw_flow(tau) - jax.scipy.linalg.expm(A * tau)))) < 1e-12
    M = jax.random.normal(jax.random.PRNGKey(0), (48, 48))
    b = jax.random.normal(jax.random.PRNGKey(1), (48, 5))
    assert float(jnp.max(jnp.abs(dense_solve(M, b) - jnp.linalg.solve(M, b)))) < 1e-10


@pytest.fixture(scope="module")
def refined():
    """`solve(problem)` without a grid: the switch-aligned refinement to the default
    tolerance."""
    return solve(problem(4000.0), throw=False)


def test_default_solve_is_accurate_when_flown(refined):
    """The issue-19 acceptance for this family: the default solve ends SUCCESS and its own
    control, flown by an independent integrator, stays within the tolerance of the plan
    (the whole way, not only at the end), and the thrust bound holds between the nodes to
    the tolerance's delta-v."""
    tol = DEFAULT_TOLERANCE
    assert int(refined.status) == Status.SUCCESS, refined.message
    assert refined.stats["mesh_passes"] >= 2        # the uniform mesh alone did not do
    flight = verify.fly(refined)
    plan = np.asarray(flight.plan_error)
    assert plan[0] < tol.position and plan[1] < tol.velocity
    assert float(refined.stats["path_violation"]) <= tol.path


def test_coarse_mesh_is_inaccurate_and_estimate_bounds_flight(refined):
    """4 uniform segments of 8 points cannot hold the two short burns: the solve converges
    but is INACCURATE; on it and on the refined mesh the estimate and the flight's largest
    distance from the plan agree within 3x (the GPOPS-II estimate on 2.4 check points per
    collocation point: the check flight is itself a collocation of the flown IVP)."""
    coarse = solve(problem(4000.0), segmented_lgr(uniform_breaks(0.0, 1.0, 4), POINTS),
                   throw=False)
    assert int(coarse.status) == Status.INACCURATE
    for sol in (coarse, refined):
        plan = np.asarray(verify.fly(sol).plan_error)
        est = np.array([float(sol.stats["error_position"]), float(sol.stats["error_velocity"])])
        assert np.all(plan <= 3.0 * est) and np.all(est <= 3.0 * plan), (plan, est)
