"""Multi-segment LG and LGL meshes (issue 19 items 3 and 5): the energy-optimal transfer on
`lg_mesh` and `lgl_mesh` against `lgr_mesh`, mesh refinement on each scheme's ladder
(`solve(problem, MeshLadder(..., scheme=...))`) and a keep-out zone (path constraints) on LG
meshes. The batch climbs a ladder of any scheme by the same code as LGR (the rung's mesh class
read from the scheme): tests/test_refine_batch.py and tests/test_sweep_refine.py refine
energy-optimal batches on LGR meshes, fuel-optimal ones on the family's LG segments,
minimum-time ones on LGL segments, and tests/test_lg_segments.py minimum-time ones on LG
segments.
The costates at the segments' joins are checked against the analytic HCW costate in
tests/test_newton.py, the operators in tests/test_accuracy.py.

One eccentric transfer (e = 0.5, 1.5 revolutions, the linear model) on a short ladder of small
meshes (2, 4, 8 segments of 12 points): the coarse mesh misses the tolerance by four decades,
so each scheme climbs, and every rung's Newton-KKT program stays cheap to compile."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxlpm as lpm
from jaxlpm import Status
from jaxlpm.batch.refine import refine_batch

E = 0.5
ORBIT = lpm.KeplerOrbit(a=6978e3 / (1.0 - E), e=E, i=0.5, raan=0.5, argp=0.2, f0=0.3)
X0 = jnp.array([10e3, 10e3, 0.0, 4.0, -3.0, 0.0])
RUNGS = ((2, 12), (4, 12), (8, 12))
SCHEMES = ("LGR", "LG", "LGL")


def problem():
    return lpm.EnergyOptimalTransfer.from_revolutions(ORBIT, X0, jnp.zeros(6), 1.5,
                                                      model="linear")


@pytest.fixture(scope="module")
def refined():
    """Per scheme: (the coarse fixed mesh's solution, the ladder's solution, its flight)."""
    out = {}
    for scheme in SCHEMES:
        coarse = lpm.solve(problem(), lpm.make_mesh(scheme, *RUNGS[0]), throw=False)
        fine = lpm.solve(problem(), lpm.MeshLadder(RUNGS, scheme=scheme))   # raises unless SUCCESS
        out[scheme] = coarse, fine, lpm.verify.fly(fine)
    return out


@pytest.mark.parametrize("scheme", SCHEMES)
def test_a_coarse_mesh_is_inaccurate_and_the_ladder_is_not(refined, scheme):
    coarse, fine, flight = refined[scheme]
    assert int(coarse.status) == Status.INACCURATE
    assert float(coarse.stats["error_position"]) > 100.0 * lpm.DEFAULT_TOLERANCE.position
    assert type(fine.grid) is type(lpm.make_mesh(scheme, 2, 12))
    assert int(fine.stats["rung"]) >= 1
    # split where the error is: unequal segments (a degree raise would keep equal breaks)
    lengths = np.diff(np.asarray(fine.grid.breaks))
    assert lengths.max() > 1.5 * lengths.min(), lengths
    # the flown miss of the refined solution (its control through an independent integrator)
    # within the tolerance the estimate was held to
    miss = np.asarray(flight.terminal_error)
    assert miss[0] < lpm.DEFAULT_TOLERANCE.position and miss[1] < lpm.DEFAULT_TOLERANCE.velocity
    # the states between the nodes: the plan against the flight
    plan = np.asarray(flight.plan_error)
    assert plan[0] < lpm.DEFAULT_TOLERANCE.position


def test_the_schemes_agree_on_the_optimum(refined):
    """Three discretisations of the same transfer, each refined until its estimate meets the
    tolerance: the same cost to 1e-9 relative (measured 1e-11 apart on the two-body model;
    the cost is quadratic in the state error, far below the 0.1 m tolerance's share of it),
    and the same initial costate to 1e-5 of its largest component (costate estimates converge
    one order slower than the states)."""
    costs = {s: float(refined[s][1].cost) for s in SCHEMES}
    for s in SCHEMES[1:]:
        assert costs[s] == pytest.approx(costs["LGR"], rel=1e-9), costs
    lam = {s: np.asarray(refined[s][1].costates(0.0)) for s in SCHEMES}
    for s in SCHEMES[1:]:
        np.testing.assert_allclose(lam[s], lam["LGR"], atol=1e-5 * np.abs(lam["LGR"]).max())


def test_a_p_rung_raises_the_degree_and_keeps_the_breaks():
    """p refinement: a rung of the same segment count with more points keeps the breaks and
    raises each segment's degree. With a 1 m, 1 mm/s tolerance, 2 x 12 LGR points are
    INACCURATE (97 m) and 2 x 24 resolve the transfer (measured 0.075 m, 1.3e-4 m/s)."""
    tolerance = lpm.Tolerance(position=1.0, velocity=1e-3)
    sol = lpm.solve(problem(), lpm.MeshLadder(((2, 12), (2, 24))), tolerance=tolerance)
    assert int(sol.stats["rung"]) == 1 and sol.grid.segment.n == 24
    np.testing.assert_array_equal(sol.grid.breaks, [-1.0, 0.0, 1.0])
    miss = np.asarray(lpm.verify.fly(sol).terminal_error)
    assert miss[0] < tolerance.position and miss[1] < tolerance.velocity


def test_a_keep_out_zone_on_lg_meshes():
    """Path constraints on an LG mesh (the augmented Lagrangian over the dense Newton-KKT):
    tests/test_safety.py's fly-by past a 1.5 km keep-out sphere, refined on LG meshes, stays
    outside it between the nodes to the tolerance (0.1 m) and touches it: the constraint is
    active, the path's closest approach within 1 m of the surface."""
    orbit = lpm.KeplerOrbit(a=7000e3, e=0.05, f0=0.4)
    free = lpm.EnergyOptimalTransfer(orbit, jnp.array([100.0, -2000.0, 50.0, 0.0, 0.0, 0.0]),
                                     jnp.array([0.0, 2000.0, 0.0, 0.0, 0.0, 0.0]),
                                     0.5 * float(orbit.period))
    zone = lpm.KeepOutEllipsoid(semi_axes=(1500.0, 1500.0, 1500.0))
    sol = lpm.solve(free.replace(constraints=(zone,)),
                    lpm.MeshLadder(((4, 10), (8, 10)), scheme="LG"))
    assert isinstance(sol.grid, lpm.LGMesh) and sol.method == "augmented-lagrangian"
    t = np.linspace(0.0, float(sol.duration), 4001)
    reach = np.linalg.norm(np.asarray(sol.states(t))[:, :3], axis=1)
    assert 1500.0 - lpm.DEFAULT_TOLERANCE.position < reach.min() < 1501.0


def test_ladders_are_checked():
    with pytest.raises(ValueError, match="scheme must be one of"):
        lpm.MeshLadder(RUNGS, scheme="Chebyshev")
    with pytest.raises(ValueError, match="refines energy-optimal, fuel-optimal"):
        lpm.solve(lpm.LQRTransfer(ORBIT.replace(e=0.0), X0, 3000.0, jnp.eye(6), jnp.eye(3)),
                  lpm.MeshLadder(RUNGS))
    with pytest.raises(ValueError, match="LGL"):       # states eliminated segment by segment
        fuel = lpm.FuelOptimalTransfer(ORBIT, jnp.zeros(6), X0, 3000.0, 0.3, 50.0, 1000.0)
        refine_batch(jax.tree_util.tree_map(lambda x: jnp.stack([x]), fuel),
                     ladder=lpm.MeshLadder(RUNGS, scheme="LGL"),
                     options=lpm.HomotopyOptions())
