"""LG and LGL meshes for the fuel-optimal and minimum-time families (issue 19): the condensed
transcription on LG segments (Garg et al. 2010's multi-interval Gauss method: each segment's
end is its start plus the Gauss quadrature of the dynamics), refinement on LG ladders, the
fuel-optimal augmented Lagrangian refined on LGL segments, and the HCW minimum-time augmented
Lagrangian on LG and LGL meshes.

References independent of the collocation: `min_time_shooting` (the exact Yamanaka-Ankersen
flow, Gauss quadrature on panels) for the minimum time, the exact adjoint flow Phi(s_f, s)^T nu
(`primer`) for the LG costate estimates, and a flight of each refined solution.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxlpm as lpm
from jaxlpm import DEFAULT_TOLERANCE, MeshLadder, Status, solve, verify
from jaxlpm.batch.refine import refine_batch
from jaxlpm.collocation.segments import (LGLMesh, LGMesh, as_segmented, segmented_lgr,
                                         segmented_mesh)
from jaxlpm.constants import R_EARTH

CIRCULAR = lpm.KeplerOrbit(a=jnp.asarray(R_EARTH + 400e3), e=jnp.asarray(0.0))
ECCENTRIC = lpm.KeplerOrbit(a=jnp.asarray(9000e3), e=jnp.asarray(0.2))
PERIOD = float(CIRCULAR.period)
# shooting's panels: 16 of 16 Gauss nodes resolve one revolution's flow to round-off
SHOOTING_PANELS, SHOOTING_NODES = np.linspace(0.0, 1.0, 17), 16


def fuel_problem():
    """4 km along-track in one period, 0.3 N on 50 kg: two short burns (tests/test_fuel_optimal)."""
    return lpm.FuelOptimalTransfer(CIRCULAR, jnp.zeros(6),
                                   jnp.array([0.0, 4000.0, 0.0, 0.0, 0.0, 0.0]),
                                   jnp.asarray(PERIOD), jnp.asarray(0.3), jnp.asarray(50.0),
                                   jnp.asarray(1000.0))


def min_time_problem(orbit):
    return lpm.MinimumTimeTransfer(orbit, jnp.zeros(6),
                                   jnp.array([0.0, 1000.0, 0.0, 0.0, 0.0, 0.0]),
                                   thrust=jnp.asarray(0.1), mass=jnp.asarray(100.0))


@pytest.fixture(scope="module")
def fuel_lg():
    """Refined on LG segments: 4 uniform segments of 8 points (too coarse for the burns),
    then meshes with breaks at the switches (4 segments of 8 already hold them)."""
    return solve(fuel_problem(), MeshLadder(((4, 8), (24, 8)), scheme="LG"), throw=False)


def test_fuel_refined_on_lg_segments_is_accurate_when_flown(fuel_lg):
    """SUCCESS on an LG mesh once the breaks follow the switches; its own control, flown by
    an independent integrator, stays within the tolerance of the plan, and the thrust bound
    holds between the nodes to the tolerance's delta-v."""
    tol = DEFAULT_TOLERANCE
    assert int(fuel_lg.status) == Status.SUCCESS, fuel_lg.message
    assert isinstance(fuel_lg.grid, LGMesh)
    assert int(fuel_lg.stats["mesh_passes"]) >= 2       # the uniform mesh alone did not do
    plan = np.asarray(verify.fly(fuel_lg).plan_error)
    assert plan[0] < tol.position and plan[1] < tol.velocity
    assert float(fuel_lg.stats["path_violation"]) <= tol.path


def test_fuel_lg_matches_lgr_and_the_exact_adjoint(fuel_lg):
    """On the same breaks the LG and LGR transcriptions give the same fuel optimum (both
    converge spectrally on segments that hold one smooth arc: 1e-6 relative leaves room for
    the 1e-9 measured), and the LG costate estimates Lambda_i / w_i + Lambda_e (the Gauss
    method's, with the quadrature row's multiplier) equal the exact adjoint flow from nu to
    the collocation error of Phi: the coast segments span 3 rad with 8 points, where the
    LGR estimates on the same breaks are 9e-6 off and the LG ones 1.2e-7 (measured)."""
    lgr = solve(fuel_problem(), segmented_lgr(np.asarray(as_segmented(fuel_lg.grid).breaks), 8),
                throw=False)
    assert int(lgr.status) in (Status.SUCCESS, Status.INACCURATE)
    assert abs(float(fuel_lg.cost) - float(lgr.cost)) < 1e-6 * float(lgr.cost)

    def costate_error(sol):
        t = np.asarray(sol.times).reshape(-1)
        exact = np.stack([np.asarray(lpm.primer(sol, tk)) for tk in t])
        return np.max(np.abs(exact - np.asarray(sol.stats["node_primers"]).reshape(-1, 3)))

    assert costate_error(fuel_lg) < min(1e-6, costate_error(lgr))


@pytest.fixture(scope="module")
def fuel_lgl():
    """Refined on LGL segments (method "augmented-lagrangian", the default there: the states
    are kept, so an LGL segment's both collocated ends are no obstacle)."""
    return solve(fuel_problem(), MeshLadder(((24, 8), (48, 8)), scheme="LGL"), throw=False)


def test_fuel_refined_on_lgl_segments_is_accurate_and_optimal(fuel_lgl, fuel_lg):
    """SUCCESS on LGL segments, flown within the tolerance of the plan, the bound held between
    the nodes; its delta-v above the LG solution's (the fuel optimum, SUCCESS and equal to
    LGR's on its breaks: above) by no more than the augmented Lagrangian's smoothing allows
    (tests/test_fuel_constrained.py: eps F* + delta C (1 + eps) over 1 - eps, C = u_max T;
    measured 7.0e-4 m/s against 3.8e-3), and not below it by more than 1e-5 relative (both
    controls fly within millimetres of the target, so each is feasible for the continuous
    problem to that accuracy and neither can be much cheaper than its optimum). The
    solution's own grid, an `LGLMesh`, solves again to the same delta-v."""
    tol = DEFAULT_TOLERANCE
    assert int(fuel_lgl.status) == Status.SUCCESS, fuel_lgl.message
    assert fuel_lgl.method == "augmented-lagrangian"
    assert isinstance(fuel_lgl.grid, LGLMesh)
    plan = np.asarray(verify.fly(fuel_lgl).plan_error)
    assert plan[0] < tol.position and plan[1] < tol.velocity
    assert float(fuel_lgl.stats["path_violation"]) <= tol.path
    assert int(fuel_lg.status) == Status.SUCCESS
    eps, delta = float(fuel_lgl.stats["eps"]), lpm.FuelALOptions().smoothing
    F, C = float(fuel_lg.cost), float(fuel_lg.problem.max_acceleration * fuel_lg.duration)
    bound = (eps * F + delta * C * (1 + eps) + eps * delta**2 * C) / (1 - eps)
    assert -1e-5 * F <= float(fuel_lgl.cost) - F <= bound
    again = solve(fuel_problem(), fuel_lgl.grid, throw=False)
    assert again.method == "augmented-lagrangian"
    assert abs(float(again.cost) - float(fuel_lgl.cost)) <= 1e-12 * F


def test_min_time_condensed_on_lg_matches_shooting():
    """Method "condensed" on an eccentric chief (e = 0.2, Tschauner-Hempel) refined on LG
    segments: SUCCESS, flown within the tolerance, and the minimum time equal to the shooting
    solution's to 1e-7 relative (measured 5e-9; LGR segments 2e-8)."""
    problem = min_time_problem(ECCENTRIC)
    sol = solve(problem, MeshLadder(((8, 8), (16, 8)), scheme="LG"), throw=False)
    assert int(sol.status) == Status.SUCCESS, sol.message
    assert isinstance(sol.grid, LGMesh)
    plan = np.asarray(verify.fly(sol).plan_error)
    assert plan[0] < DEFAULT_TOLERANCE.position and plan[1] < DEFAULT_TOLERANCE.velocity
    shot = lpm.min_time_shooting(problem, SHOOTING_PANELS, SHOOTING_NODES)
    assert bool(shot.converged)
    assert abs(float(sol.duration) - float(shot.duration)) < 1e-7 * float(shot.duration)


def test_min_time_batch_on_lg_ladder_equals_single_solves():
    """`refine_batch` on an LG ladder solves each member on the same uniform meshes as its
    single solve (method "condensed" refines uniformly): the same rung and duration."""
    problems = [min_time_problem(ECCENTRIC),
                min_time_problem(ECCENTRIC).replace(xf=jnp.array([0.0, -600.0, 100.0, 0.0,
                                                                  0.0, 0.0]))]
    ladder = MeshLadder(((8, 8), (16, 8)), scheme="LG")
    batch = refine_batch(jax.tree_util.tree_map(lambda *x: jnp.stack(x), *problems),
                         ladder=ladder)
    for i, problem in enumerate(problems):
        single = solve(problem, ladder, throw=False)
        assert int(batch["status"][i]) == int(single.status)
        assert int(batch["rung"][i]) == int(single.stats["mesh_passes"]) - 1
        assert abs(float(batch["cost"][i]) - float(single.duration)) < 1e-10 * float(
            single.duration)


@pytest.mark.parametrize("make_mesh, bound", [(lpm.lg_mesh, 1e-6), (lpm.lgl_mesh, 1e-4)])
def test_min_time_augmented_lagrangian_on_lg_and_lgl_meshes(make_mesh, bound):
    """HCW minimum time by the augmented Lagrangian on 8 segments of 8 LG or LGL points:
    SUCCESS, and the time above the shooting solution's by less than `bound` (relative).
    LGL meshes converge more slowly in the time (each segment collocates both its ends, so
    its controls meet more conditions): measured 1.1e-5 above on 8 x 8 points, 6e-8 on
    16 x 8, where LG meshes give 1.5e-8 on 8 x 8."""
    problem = min_time_problem(CIRCULAR)
    sol = solve(problem, make_mesh(8, 8), throw=False)
    assert int(sol.status) == Status.SUCCESS, sol.message
    shot = lpm.min_time_shooting(problem, SHOOTING_PANELS, SHOOTING_NODES)
    excess = (float(sol.duration) - float(shot.duration)) / float(shot.duration)
    assert -1e-9 < excess < bound


def test_lgl_segments_are_refused_where_states_are_eliminated():
    """The condensed transcriptions (the fuel homotopy, minimum-time method "condensed")
    eliminate the states segment by segment, which an LGL segment (both ends collocated) does
    not allow: a clear ValueError at the boundary, naming the fuel family's way (the batch's
    refusal: tests/test_meshes.py)."""
    lgl_segments = segmented_mesh(np.linspace(0.0, 1.0, 5), 8, "LGL")
    with pytest.raises(ValueError, match="LGL segment collocates both its ends.*"
                                         "augmented-lagrangian"):
        solve(fuel_problem(), lpm.lgl_mesh(4, 8), method="homotopy")
    with pytest.raises(ValueError, match="augmented-lagrangian"):
        solve(fuel_problem(), lgl_segments, method="homotopy")
    with pytest.raises(ValueError, match="augmented-lagrangian"):
        solve(fuel_problem(), MeshLadder(((24, 8),), scheme="LGL"), method="homotopy")
    # minimum time on LGL segments: the augmented Lagrangian, the default there
    # (tests/test_min_time_eccentric.py), never "condensed"
    with pytest.raises(ValueError, match="augmented-lagrangian"):
        solve(min_time_problem(ECCENTRIC), MeshLadder(((8, 8),), scheme="LGL"),
              method="condensed")
    with pytest.raises(ValueError, match="LGL segment collocates both its ends.*"
                                         "augmented-lagrangian"):
        solve(min_time_problem(ECCENTRIC), lgl_segments, method="condensed")
