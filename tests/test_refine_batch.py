"""Batched mesh refinement (`jaxlpm.batch.refine.refine_batch`) of the fuel-optimal,
minimum-time and LQR families (issue 19 item 4; the energy-optimal family's is in test_accuracy.py):
each member climbs the same ladder as its single solve (`solve(problem)` without a grid) and
ends on the same rung with the same cost, the members that need no refinement stop on the
first rung, and the fuel-optimal gradients are taken on each member's final mesh."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxlpm as lpm
from jaxlpm import FuelOptimalTransfer, KeplerOrbit, Status
from jaxlpm.batch.refine import refine_batch
from jaxlpm.solvers.min_time_condensed import min_time_shooting
from jaxlpm.cases import jiang2011

ORBIT = KeplerOrbit(a=jnp.asarray(10000e3), e=jnp.asarray(0.3))
PERIOD = float(ORBIT.period)


def stack(problems):
    return jax.tree_util.tree_map(lambda *x: jnp.stack(x), *problems)


def fuel(e, y):
    """tests/test_fuel_eccentric.py's transfer: y m along-track in one period, 0.3 N on
    1000 kg."""
    return FuelOptimalTransfer(ORBIT.replace(e=jnp.asarray(e)), jnp.zeros(6),
                               jnp.array([0.0, y, 0.0, 0.0, 0.0, 0.0]), jnp.asarray(PERIOD),
                               jnp.asarray(0.3), jnp.asarray(50.0), jnp.asarray(1000.0))


def min_time(e):
    """tests/test_min_time_eccentric.py's transfer (0.05 N on 200 kg)."""
    return lpm.MinimumTimeTransfer(lpm.KeplerOrbit(a=10000e3, e=e), jnp.zeros(6),
                                   jnp.array([500.0, 3000.0, -100.0, 0.0, 0.0, 0.0]), 0.05,
                                   200.0)


@pytest.fixture(scope="module")
def fuel_batch():
    members = [fuel(0.2, 8000.0), fuel(0.3, 6000.0)]
    return members, refine_batch(stack(members), gradients=True)


def test_fuel_members_end_where_their_single_solves_end(fuel_batch):
    """Both members need aligned passes (rung >= 1) and end SUCCESS on the rung and with
    the delta-v of `solve(problem)`: the same meshes (breaks at the same switches) and the
    same homotopy, so the same numbers to round-off, which the throttle of a partial point
    amplifies by its slope 1 / (2 eps) = 5e5 at the homotopy's last eps (measured 1.4e-10
    relative on the family's LG ladder; 1e-9 asserted)."""
    members, out = fuel_batch
    assert np.all(out["status"] == Status.SUCCESS)
    assert np.all(out["rung"] >= 1)
    for i, problem in enumerate(members):
        single = lpm.solve(problem)
        assert out["rung"][i] == int(single.stats["mesh_passes"]) - 1
        assert out["segments"][i] == single.grid.n_segments
        assert abs(out["cost"][i] - float(single.cost)) <= 1e-9 * float(single.cost)
        assert out["error_position"][i] <= lpm.DEFAULT_TOLERANCE.position


def test_fuel_gradient_is_taken_on_the_final_mesh(fuel_batch):
    """d delta-v / d xf_y from the batch (implicit, on the member's final mesh) against
    central differences of the delta-v on that mesh (h = 1 m of 8 km). The final mesh (the
    family's LG ladder) has two points inside the smoothed throttle's transition
    (stats["partial_throttle"]), whose slope 1 / (2 eps) = 5e5 amplifies the homotopy's
    residual tolerance (1e-11) in the derivative: measured 1.1e-5 relative at h = 1 m, 1.7e-5
    at h = 0.1 m (on the LGR ladder, without such points, 1.7e-7); 1e-4 asserted."""
    members, out = fuel_batch
    problem = members[0]
    mesh = lpm.solve(problem).grid

    def dv(y):
        return float(lpm.solve(problem.replace(xf=problem.xf.at[1].set(y)), mesh).cost)

    y, h = float(problem.xf[1]), 1.0
    fd = (dv(y + h) - dv(y - h)) / (2.0 * h)
    assert abs(out["dcost_dxf"][0][1] - fd) <= 1e-4 * abs(fd), (out["dcost_dxf"][0][1], fd)


def test_min_time_members_climb_only_where_they_must():
    """With the position tolerance at 1 cm, the e = 0.3 transfer (4.5 cm on 16 x 8 points)
    climbs and the e = 0.1 one (4 mm) stops on the first rung; each ends on the rung and with
    the duration of its single solve at that tolerance (the same uniform meshes: 1e-10)."""
    tolerance = lpm.Tolerance(position=0.01)
    members = [min_time(0.3), min_time(0.1)]
    out = refine_batch(stack(members), tolerance=tolerance)
    assert np.all(out["status"] == Status.SUCCESS)
    assert out["rung"][0] >= 1 and out["rung"][1] == 0
    for i, problem in enumerate(members):
        single = lpm.solve(problem, tolerance=tolerance)
        assert out["rung"][i] == int(single.stats["mesh_passes"]) - 1
        assert abs(out["cost"][i] - float(single.duration)) <= 1e-10 * float(single.duration)
        assert out["error_position"][i] <= 0.01


def test_min_time_batch_on_lgl_segments_keeps_the_true_anomaly_clock():
    """A batch of eccentric chiefs on the linear model on an LGL ladder: the augmented
    Lagrangian on the chief's true anomaly (the batch's clock decided from the concrete
    members: traced, an eccentric member would be INVALID_INPUT on the HCW clock). Both SUCCESS
    and within 1e-7 of the shooting t_f (2 x 48 LGL points resolve the transfer: measured
    3e-9 at e = 0.3); with gradients=True, dt_f/dT (s/N) by the implicit function theorem
    equals central differences of the single solve on the same mesh to 1e-6 (step 1e-6 N:
    truncation ~1e-12 of t_f's curvature, the KKT tolerance ~1e-12 / 1e-6 relative)."""
    members = [min_time(0.3), min_time(0.1)]
    ladder = lpm.MeshLadder(((2, 48),), scheme="LGL")
    out = refine_batch(stack(members), ladder=ladder, gradients=True)
    assert np.all(out["status"] == Status.SUCCESS)
    for i, problem in enumerate(members):
        shot = float(min_time_shooting(problem, np.linspace(0.0, 1.0, 201)).duration)
        assert abs(out["cost"][i] - shot) < 1e-7 * shot
    h = 1e-6
    t_f = [float(lpm.solve(members[0].replace(thrust=jnp.asarray(0.05 + s * h)),
                           lpm.lgl_mesh(2, 48), throw=False).duration) for s in (1.0, -1.0)]
    fd = (t_f[0] - t_f[1]) / (2 * h)
    np.testing.assert_allclose(out["dcost_dthrust"][0], fd, rtol=1e-6)


def test_bad_requests():
    with pytest.raises(ValueError, match="not differentiated"):
        refine_batch(stack([min_time(0.3)]), gradients=True)
    with pytest.raises(ValueError, match="leading member axis"):
        refine_batch(min_time(0.3))
    with pytest.raises(ValueError, match="refine_batch refines"):
        refine_batch(ORBIT)
    with pytest.raises(ValueError, match="takes no options"):
        refine_batch(stack([lqr(*jiang2011.weights())]), options=lpm.NewtonOptions())


def lqr(Q, R):
    """jiang2011's chief and chaser over one period, terminal weight zero."""
    return lpm.LQRTransfer(jiang2011.chief(), jiang2011.initial_state(),
                           2.0 * np.pi / jiang2011.mean_motion(), Q, R, terminal="weight")


def test_lqr_members_double_their_steps_where_they_must():
    """jiang2011's weights resolve the closed loop on 512 sweep steps; Q = I, R = I in SI
    (closed-loop rates ~900 n) need 1024 (tests/test_riccati.py). Each member ends on the step
    count and cost of its single solve (the same sweep: 1e-12), and its gradient d cost/d x0,
    taken on its final steps, is P(0) x0 (the cost is 1/2 x0^T P(0) x0 with S_T = 0) up to
    the cost's quadrature error against that form (measured 2e-14 and 6e-8: the Q = I
    control varies 900 times faster than the orbit)."""
    members = [lqr(*jiang2011.weights()), lqr(np.eye(6), np.eye(3))]
    out = refine_batch(stack(members), gradients=True)
    assert np.all(out["status"] == Status.SUCCESS)
    np.testing.assert_array_equal(out["rung"], [0, 1])
    np.testing.assert_array_equal(out["segments"], [512, 1024])
    for i, problem in enumerate(members):
        single = lpm.solve(problem)
        assert out["segments"][i] == int(single.stats["steps"])
        assert abs(out["cost"][i] - float(single.cost)) <= 1e-12 * float(single.cost)
        g = np.asarray(single.stats["P0"]) @ np.asarray(problem.x0)
        np.testing.assert_allclose(out["dcost_dx0"][i], g, rtol=0, atol=1e-6 * np.abs(g).max())
