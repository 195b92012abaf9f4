"""Monte Carlo (re-plan per sample of a user's dispersion, of any family; one plan flown
with execution errors on its own model or another), the Solution's delta-v, statistics over
SUCCESS members only, and batched sensitivities (d cost, d delta-v, d u(t0)/d x0) against
central differences. Small grids and sample counts: compile time dominates; the persistent
cache (conftest.py) serves reruns."""

import dataclasses
import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

jax.config.update("jax_enable_x64", True)

import jaxlpm as lpm  # noqa: E402
from jaxlpm.batch import (ExecutionErrors, SweepFamily, converged_statistics,  # noqa: E402
                          execution_draws, execution_monte_carlo, replan_monte_carlo,
                          sensitivity_family, sweep, transfer_family)
from jaxlpm.batch.montecarlo import _rotation  # noqa: E402
from jaxlpm.cases import mei2010  # noqa: E402
from jaxlpm.status import Status  # noqa: E402

# small grids for speed: solutions that converge unresolved are accepted (conftest)
pytestmark = pytest.mark.usefixtures("loose_accuracy")


def test_delta_v_quadrature():
    """delta_v (the grid's quadrature of |u| dt) against a dense trapezoid integral (2e5
    steps, error ~1e-10) of the interpolated |u(t)| at N = 64. The cost, which the law computes
    by the same rule from |u|^2, agrees with the same dense integral to ~1e-8, which checks the
    reference and the time map; |u| is a norm, less smooth than |u|^2 where u is small, so its
    quadrature converges more slowly: 1e-4 relative. Cauchy-Schwarz: dv^2 <= 2 J T."""
    plan = lpm.solve(mei2010.problem(), lpm.lgl(65), method="kkt")
    T = float(plan.problem.duration)
    t = np.linspace(0.0, T, 200_001)
    u = np.asarray(jax.jit(jax.vmap(plan.controls))(jnp.asarray(t)))
    dv = float(plan.delta_v)
    assert dv == pytest.approx(np.trapezoid(np.linalg.norm(u, axis=1), t), rel=1e-4)
    assert float(plan.cost) == pytest.approx(0.5 * np.trapezoid(np.sum(u**2, axis=1), t),
                                             rel=1e-6)
    assert dv**2 <= 2.0 * float(plan.cost) * T


def test_statistics_leave_out_non_converged():
    """Synthetic family (no solver): members with x > 0.5 report MAX_ITERATIONS and a huge
    value; they are counted and listed, and the statistics see only the others."""
    x = np.array([0.1, 0.9, 0.2, 0.3, 0.7])

    def solver(p, grid, method, options):
        bad = p["x"] > 0.5
        return dict(status=jnp.where(bad, Status.MAX_ITERATIONS, Status.SUCCESS).astype(
                        jnp.int32), value=jnp.where(bad, 1e9, p["x"] * grid))

    fam = SweepFamily(name="synthetic", build=lambda p: p, grid=float, solver=solver,
                      record=dict)
    result = sweep(fam, dict(x=x), [2], chunk_size=2, progress=False)
    s = result.summary()["2"]
    assert s["converged"] == 3 and s["not_converged"] == [1, 4]
    assert s["status_counts"] == {"SUCCESS": 3, "MAX_ITERATIONS": 2}
    stats = result.statistics(columns=("value",))[2]["value"]
    good = 2.0 * x[[0, 2, 3]]
    assert stats["converged"] == 3 and stats["not_converged"] == [1, 4]
    assert stats["mean"] == pytest.approx(good.mean(), rel=1e-15)
    assert stats["percentiles"][50.0] == pytest.approx(np.median(good), rel=1e-15)
    none = converged_statistics(np.ones(2), np.full(2, Status.STALLED))
    assert none["converged"] == 0 and np.isnan(none["mean"])


def test_replan_monte_carlo_is_reproducible():
    """mei2010's own dispersion (its case's, on the linear model): same key, the same draw
    (the dispersion's parameters in the table's problem.* columns) and bit-identical results;
    another key, another draw. KKT law on lgl(9), 6 samples."""
    key = jax.random.key(7)
    linear = functools.partial(mei2010.dispersion, model="linear")
    runs = [replan_monte_carlo(key, 6, linear, [9], method="kkt", chunk_size=6, batch_size=1,
                               progress=False) for _ in range(2)]
    table = mei2010.dispersion_parameters(linear(key, 6))
    a, b = runs[0].tables[9], runs[1].tables[9]
    for name in ("e", "a"):
        np.testing.assert_array_equal(a[f"problem.orbit.{name}"], table[name])
    for name in ("duration", "x0"):
        np.testing.assert_array_equal(a[f"problem.{name}"], table[name])
    np.testing.assert_array_equal(a["duration"], table["duration"])    # the Solution's
    for name in a:
        np.testing.assert_array_equal(a[name], b[name])
    assert runs[0].converged() == {9: 6}
    s = runs[0].statistics()[9]
    assert s["delta_v"]["converged"] == 6 and s["cost"]["min"] > 0.0
    other = mei2010.dispersion_parameters(linear(jax.random.key(8), 6))
    assert not np.any(other["e"] == table["e"])


MASS = 100.0         # kg


def release_dispersion(key, n):
    """A user's dispersion of another family: minimum-time releases from rest to a point 50 m
    ahead at rest, the chief at 500 km perigee altitude, circular in the first sample and
    e ~ U[0, 0.3] in the others, the thrust U[0.2, 1] N, the start dispersed by 1 m and
    1 mm/s (one sigma per axis) -- one batched MinimumTimeTransfer."""
    def one(k):
        k_thrust, k_r, k_v, k_e = jax.random.split(k, 4)
        e = jax.random.uniform(k_e, (), maxval=0.3)
        orbit = lpm.KeplerOrbit(a=6878.137e3 / (1.0 - e), e=e)
        x0 = jnp.concatenate([jax.random.normal(k_r, (3,)), 1e-3 * jax.random.normal(k_v, (3,))])
        return lpm.MinimumTimeTransfer(orbit, x0, jnp.array([0.0, 50.0, 0.0, 0.0, 0.0, 0.0]),
                                       jax.random.uniform(k_thrust, (), minval=0.2, maxval=1.0),
                                       jnp.asarray(MASS))

    draw = jax.vmap(one)(jax.random.split(key, n))
    circular = draw.orbit.replace(a=draw.orbit.a.at[0].set(6878.137e3),
                                  e=draw.orbit.e.at[0].set(0.0))
    return draw.replace(orbit=circular)


def test_replan_monte_carlo_of_another_family():
    """`replan_monte_carlo` with a user's dispersion of minimum-time transfers (the default
    method, grids lg(8)): every sample SUCCESS, its parameters in the table, the record from
    its Solution (t_f, delta_v = (T / m) t_f at constant thrust, to the unit-direction
    tolerance 1e-9). The traced batch is solved on the chief's true anomaly, so its eccentric
    samples are solved (until 2026-12-08 a traced batch took the HCW clock and they were
    INVALID_INPUT), and each sample's t_f is its single solve's to 1e-9 relative (the
    solver's convergence; measured 4e-16): an eccentric one on the same clock, the circular
    one on the HCW clock of a concrete HCW transfer. 4 samples, one compile (~10 s)."""
    key = jax.random.key(5)
    result = replan_monte_carlo(key, 4, release_dispersion, [8], grid=lpm.lg, chunk_size=4,
                                progress=False)
    t = result.tables[8]
    drawn = release_dispersion(key, 4)
    np.testing.assert_array_equal(t["problem.thrust"], drawn.thrust)
    np.testing.assert_array_equal(t["problem.x0"], drawn.x0)
    assert t["problem.duration_bounds"].shape == (4, 2)
    assert result.converged() == {8: 4}
    assert np.all(t["duration"] >= t["duration_lower_bound"])
    np.testing.assert_allclose(t["delta_v"], t["problem.thrust"] / MASS * t["duration"],
                               rtol=1e-8)
    stats = result.statistics(columns=("duration",))[8]["duration"]
    assert stats["converged"] == 4 and stats["min"] > 0.0
    assert np.all(t["problem.orbit.e"][1:] > 0.0)
    for i in (0, 3):
        one = jax.tree_util.tree_map(lambda x: x[i], drawn)
        single = lpm.solve(one, lpm.lg(8))
        np.testing.assert_allclose(t["duration"][i], float(single.duration), rtol=1e-9)


def test_replan_monte_carlo_checks_the_draw():
    with pytest.raises(ValueError, match="leading axis of every array leaf"):
        replan_monte_carlo(jax.random.key(0), 3, lambda key, n: release_dispersion(
            key, n).replace(duration_bounds=jnp.array([0.0, jnp.inf])), [8], grid=lpm.lg)
    with pytest.raises(ValueError, match="must return 3 problems"):
        replan_monte_carlo(jax.random.key(0), 3, lambda key, n: release_dispersion(key, 2),
                           [8], grid=lpm.lg)


def test_rotation():
    """Rodrigues' rotation: orthogonal, det 1, keeps its axis, turns a perpendicular vector by
    the angle."""
    axis = np.array([1.0, 2.0, 2.0]) / 3.0
    R = np.asarray(_rotation(jnp.asarray(axis), 0.3))
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-15)
    assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-15)
    np.testing.assert_allclose(R @ axis, axis, atol=1e-15)
    v = np.array([2.0, -1.0, 0.0]) / np.sqrt(5.0)              # perpendicular to the axis
    assert np.arccos(v @ R @ v) == pytest.approx(0.3, rel=1e-12)


def test_execution_draws():
    """Sample moments of 20000 draws against the requested sigmas: the standard error of a
    sample standard deviation is sigma / sqrt(2 n) = 0.5 %; asserted at 3 %."""
    errors = ExecutionErrors(magnitude=0.02, direction=0.01, position=5.0, velocity=0.05)
    d = {k: np.asarray(v) for k, v in execution_draws(jax.random.key(3), 20_000, errors).items()}
    np.testing.assert_allclose(np.linalg.norm(d["axis"], axis=1), 1.0, atol=1e-14)
    assert np.std(d["gain"] - 1.0) == pytest.approx(0.02, rel=0.03)
    assert np.std(d["angle"]) == pytest.approx(0.01, rel=0.03)
    np.testing.assert_allclose(np.std(d["dx0"], axis=0), [5.0] * 3 + [0.05] * 3, rtol=0.03)
    with pytest.raises(ValueError, match="standard deviation"):
        ExecutionErrors(position=-1.0)


@pytest.fixture(scope="module")
def plan():
    """mei2010's KKT plan on lgl(33) (its problem's model: linear)."""
    return lpm.solve(mei2010.problem(), lpm.lgl(33), method="kkt")


@pytest.fixture(scope="module")
def linear_flights(plan):
    """The plan flown 16 times on its own model (the default: linear) with thrust magnitude
    and navigation errors (no direction error: the flight is then affine in them)."""
    errors = ExecutionErrors(magnitude=0.02, position=10.0, velocity=0.01)
    return plan, errors, execution_monte_carlo(jax.random.key(11), plan, 16, errors)


def test_the_nominal_flight_is_verify_fly(linear_flights):
    """The default model is the plan's own, as `jaxlpm.verify.fly`'s, and the error-free row
    is its flight: the same propagator and control, other save times (dense output), so the
    same terminal error to the integrator's tolerance. The two are different programs
    (compiled with different XLA options: the Monte Carlo's batch, `verify.fly`'s fast
    profile), so their round-off differs and the adaptive steps with it: the integrator's
    rtol = atol = 1e-12 on states scaled to the transfer's ~1.4e4 m leaves ~1e-8 m (measured
    8e-9 m on a 5.6 m miss); asserted at 1e-7 m and 1e-10 m/s."""
    plan, _, r = linear_flights
    assert r["model"] == "linear"
    flight = lpm.verify.fly(plan)
    np.testing.assert_allclose(r["nominal"][0], flight.terminal_error[0], rtol=0, atol=1e-7)
    np.testing.assert_allclose(r["nominal"][1], flight.terminal_error[1], rtol=0, atol=1e-10)


def test_the_j2_model_takes_the_problem_j2(plan):
    """model "j2" flies with the plan's problem's j2: with j2 = 0 it is the two-body flight
    (bit for bit: the same right-hand side with a zero term), with Earth's J2 it is not."""
    flat = dataclasses.replace(plan, problem=plan.problem.replace(j2=jnp.asarray(0.0)))
    earth = dataclasses.replace(plan, problem=plan.problem.replace(j2=jnp.asarray(1.08e-3)))
    errors = ExecutionErrors(position=10.0)
    key = jax.random.key(2)
    two_body = execution_monte_carlo(key, flat, 2, errors, model="two-body")
    j2_zero = execution_monte_carlo(key, flat, 2, errors, model="j2")
    j2_earth = execution_monte_carlo(key, earth, 2, errors, model="j2")
    np.testing.assert_array_equal(j2_zero["final_state"], two_body["final_state"])
    assert np.all(np.abs(j2_earth["position_miss"] - two_body["position_miss"]) > 100.0)


def test_execution_monte_carlo_checks_its_plan(plan):
    batch = jax.tree_util.tree_map(lambda x: jnp.stack([x, x]), plan)
    with pytest.raises(ValueError, match="unbatched"):
        execution_monte_carlo(jax.random.key(0), batch, 2, ExecutionErrors())
    with pytest.raises(ValueError, match="model must be one of"):
        execution_monte_carlo(jax.random.key(0), plan, 2, ExecutionErrors(), model="hcw")


def test_execution_errors_on_the_linear_model(linear_flights):
    """On the linear model the final state is affine in the errors:
    x(T) - x_nominal(T) = Phi(T) dx0 + (gain - 1) b. Fit Phi and b (7 columns) by least
    squares on 8 samples, predict the other 8. Exact but for the integrator (rtol 1e-12 on
    states scaled to the 14 km offset): asserted at 1e-6 of the deviations' size."""
    _, _, r = linear_flights
    assert np.all(r["status"] == Status.SUCCESS)
    dev = r["final_state"] - r["nominal_final_state"]
    regressors = np.column_stack([r["dx0"], r["gain"] - 1.0])
    coef = np.linalg.lstsq(regressors[:8], dev[:8], rcond=None)[0]
    scale = np.max(np.abs(dev), axis=0)
    np.testing.assert_allclose(regressors[8:] @ coef / scale, dev[8:] / scale, atol=1e-6)
    stats = r["statistics"]["position_miss"]
    assert stats["converged"] == 16
    assert stats["percentiles"][5.0] <= stats["percentiles"][50.0] <= stats["percentiles"][95.0]


def test_execution_monte_carlo_is_reproducible(linear_flights):
    plan, errors, r = linear_flights
    again = execution_monte_carlo(jax.random.key(11), plan, 16, errors, model="linear")
    for name in ("gain", "dx0", "final_state", "position_miss"):
        np.testing.assert_array_equal(again[name], r[name])


def test_sensitivities_against_central_differences():
    """d cost / d (e, revolutions, x0) and d delta_v / d e (e with the perigee radius held),
    and the gain d u(t0) / d x0, from one batched sensitivity sweep (KKT law, lgl(9)) whose
    members include the central-difference neighbours of the base member.
    Cost is quadratic and u linear in x0 for the LQ law, so their central differences are
    exact but for round-off: ~1e-16 relative over a relative step of 1e-4 (1 m of 14 km),
    times the KKT system's conditioning: 1e-7. For e (h = 1e-5) and revolutions (h = 1e-4)
    the truncation error is O(h^2) with O(1) relative third derivatives: 1e-6."""
    fam = sensitivity_family(transfer_family("mei2010", mei2010.problem(), "kkt"))
    e0, rev0, x0 = 0.2, 2.0, np.asarray(mei2010.problem().x0)
    steps = dict(e=1e-5, revolutions=1e-4, x0=(1.0, 1e-3))      # m, then m/s (index 0, 4)
    rows = [(e0, rev0, x0)]
    rows += [(e0 + s * steps["e"], rev0, x0) for s in (1, -1)]
    rows += [(e0, rev0 + s * steps["revolutions"], x0) for s in (1, -1)]
    for i, h in zip((0, 4), steps["x0"]):
        rows += [(e0, rev0, x0 + s * h * np.eye(6)[i]) for s in (1, -1)]
    params = dict(e=np.array([r[0] for r in rows]), revolutions=np.array([r[1] for r in rows]),
                  x0=np.array([r[2] for r in rows]))
    t = sweep(fam, params, [9], chunk_size=len(rows), progress=False).tables[9]
    assert np.all(t["status"] == Status.SUCCESS)

    def central(column, k):                    # rows 2k+1, 2k+2 hold the +/- neighbours
        return (t[column][2 * k + 1] - t[column][2 * k + 2])

    assert t["dcost_de"][0] == pytest.approx(central("cost", 0) / (2 * steps["e"]), rel=1e-6)
    assert t["ddelta_v_de"][0] == pytest.approx(central("delta_v", 0) / (2 * steps["e"]),
                                                rel=1e-6)
    assert t["dcost_drevolutions"][0] == pytest.approx(
        central("cost", 1) / (2 * steps["revolutions"]), rel=1e-6)
    for k, (i, h) in enumerate(zip((0, 4), steps["x0"]), start=2):
        assert t["dcost_dx0"][0, i] == pytest.approx(central("cost", k) / (2 * h), rel=1e-7)
        gain = central("initial_control", k) / (2 * h)
        np.testing.assert_allclose(t["control_gain"][0, :, i], gain,
                                   atol=1e-7 * np.max(np.abs(gain)))


def test_sensitivity_wrt_must_name_parameters():
    fam = sensitivity_family(transfer_family("mei2010", mei2010.problem(), "kkt"),
                             wrt=("duration",))
    with pytest.raises(ValueError, match="wrt names"):
        sweep(fam, dict(e=np.array([0.1])), [9], progress=False)
