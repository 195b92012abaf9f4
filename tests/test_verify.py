"""Verification propagators against independent computations, and the mei2010 reproduction."""

import json
import os
import subprocess
import sys

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.integrate import solve_ivp

jax.config.update("jax_enable_x64", True)

from jaxlpm import KeplerOrbit, MinimumTimeTransfer, Status, lgl, solve  # noqa: E402
from jaxlpm.cases import mei2010  # noqa: E402
from jaxlpm.constants import J2_EARTH, R_EARTH  # noqa: E402
from jaxlpm.dynamics import relative_inertial_rhs, yamanaka_ankersen_stm  # noqa: E402
from jaxlpm.orbits import (elements_to_state, lvlh_to_relative_inertial, lvlh_to_th,  # noqa: E402
                           relative_inertial_to_lvlh, th_to_lvlh, time_from_true_anomaly,
                           true_anomaly_from_time)
from jaxlpm.solution import PAD_TO, ControlInterpolant  # noqa: E402
from jaxlpm.verify import min_time_shooting, propagate_linear, propagate_nonlinear  # noqa: E402

ORBIT = KeplerOrbit(a=jnp.asarray(9500e3), e=jnp.asarray(0.3), i=jnp.asarray(0.5),
                    raan=jnp.asarray(0.5), argp=jnp.asarray(0.2), f0=jnp.asarray(0.4))
X0 = jnp.array([800.0, -1200.0, 300.0, 0.4, 0.2, -0.3])


@pytest.fixture(scope="module")
def propagators():
    return jax.jit(propagate_linear), jax.jit(propagate_nonlinear)


def zero_control(f0, fT):
    tau = jnp.full(PAD_TO, 10.0).at[0].set(0.0)
    bary = jnp.zeros(PAD_TO).at[0].set(1.0)
    return ControlInterpolant(tau, bary, jnp.zeros((PAD_TO, 3)), f0, fT, variable="anomaly")


def test_linear_propagation_matches_yamanaka_ankersen(propagators):
    T = 2.5 * float(ORBIT.period)
    fT = true_anomaly_from_time(ORBIT, T)
    _, xs, status = propagators[0](ORBIT, X0, T, zero_control(ORBIT.f0, fT))
    e, k2 = ORBIT.e, ORBIT.k2
    ref = th_to_lvlh(yamanaka_ankersen_stm(fT, ORBIT.f0, T, e, k2) @ lvlh_to_th(X0, ORBIT.f0, e, k2),
                     fT, e, k2)
    assert int(status) == Status.SUCCESS
    # Dopri8 at rtol 1e-12 over 2.5 revolutions against the closed-form STM: 1e-9 leaves room
    # for error accumulation over ~1e3 steps; a wrong frame or sign gives O(1).
    assert float(jnp.max(jnp.abs(xs[-1] - ref)) / jnp.max(jnp.abs(ref))) < 1e-9


def test_nonlinear_tends_to_linear_for_small_separation(propagators):
    """The linearisation error is second order in the separation, so the RELATIVE difference
    between the nonlinear and linear flights must scale linearly with the initial offset."""
    T = float(ORBIT.period)
    ci = zero_control(ORBIT.f0, true_anomaly_from_time(ORBIT, T))

    def rel(scale):
        _, lin, _ = propagators[0](ORBIT, X0 * scale, T, ci)
        _, non, _ = propagators[1](ORBIT, X0 * scale, T, ci)
        return float(jnp.max(jnp.abs(non[-1] - lin[-1])) / jnp.max(jnp.abs(lin[-1])))

    small, smaller = rel(1e-3), rel(1e-4)
    # X0 drifts to ~110 km in one revolution; at 1e-3 of it the separation stays ~100 m, so
    # the second-order term is ~ 100 m / 6.6e6 m ~ 1e-5 relative.
    assert small < 1e-4
    # Linear scaling to 1 %: integration error (~1e-12 relative) is far below these terms.
    assert small / smaller == pytest.approx(10.0, rel=1e-2)


def test_diffrax_against_scipy_with_control(propagators):
    """The nonlinear propagator (diffrax Dopri8) against scipy's DOP853 on the same RHS."""
    sol = solve(mei2010.problem().replace(orbit=ORBIT, x0=X0, duration=jnp.asarray(6000.0)),
                lgl(17), method="kkt")
    ci = sol.trajectory.flight_control()
    _, xs, status = propagators[1](ORBIT, X0, 6000.0, ci)
    rc, vc = elements_to_state(ORBIT)
    dr, dv = lvlh_to_relative_inertial(rc, vc, X0)
    rhs = jax.jit(lambda s, f: jnp.concatenate([
        relative_inertial_rhs(s, ci(f), ORBIT.mu, 0.0, R_EARTH),
        (jnp.linalg.norm(jnp.cross(s[:3], s[3:6])) / jnp.dot(s[:3], s[:3]))[None]]))
    y0 = np.concatenate([rc, vc, dr, dv, [float(ORBIT.f0)]])
    y = solve_ivp(lambda t, y: np.asarray(rhs(y[:12], y[12])), (0, 6000.0), y0,
                  method="DOP853", rtol=1e-12, atol=1e-9).y[:, -1]
    ref = relative_inertial_to_lvlh(y[:3], y[3:6], y[6:9], y[9:12])
    assert int(status) == Status.SUCCESS
    # Two 8th-order integrators at rtol 1e-12; relative states differenced from 1e7 m orbits
    # carry ~1e-12 * 1e7 m = 1e-5 m of integration error each.
    np.testing.assert_allclose(xs[-1, :3], ref[:3], atol=1e-4)
    np.testing.assert_allclose(xs[-1, 3:], ref[3:], atol=1e-7)


def test_a_short_burn_after_a_long_coast_is_flown():
    """A control on three segments (a 2000 s coast from rest, a 5 s burn at 1e-2 m/s^2, a
    5 s coast) on the HCW model: from rest the adaptive steps grow tenfold a step over the
    coast, and without a step inside each segment one passed over the burn unseen (a
    fuel-optimal solution's 8 s burn flew 2.9 km wide of its plan, experiments/
    fuel_refine_dispersion.py, before 2026-12-07). With the segments' middles as step times
    (`Collocated.step_times`) the flight gains the burn's delta-v, 5e-2 m/s along the burn,
    up to the HCW coupling over 10 s (n t ~ 1e-2 at this orbit: a 2 % allowance)."""
    from jaxlpm.collocation.segments import make_mesh
    from jaxlpm.solution.collocated import control_interpolant

    orbit = KeplerOrbit(a=jnp.asarray(7000e3), e=jnp.asarray(0.0))
    T, burn = 2010.0, jnp.array([0.0, 1e-2, 0.0])
    breaks = np.array([0.0, 2000.0, 2005.0, T])
    mesh = make_mesh("LGR", 3, 4, jnp.asarray(2.0 * breaks / T - 1.0))
    values = jnp.concatenate([jnp.zeros((4, 3)), jnp.tile(burn, (4, 1)), jnp.zeros((4, 3))])
    control = control_interpolant(mesh, values, 0.0, T, variable="time")
    middles = 0.5 * (breaks[1:] + breaks[:-1])
    v = np.asarray(propagate_linear(orbit, jnp.zeros(6), T, control, 2,
                                    jnp.asarray(middles))[1][-1, 3:])
    assert v[1] == pytest.approx(5e-2, rel=2e-2)
    assert np.linalg.norm(v) == pytest.approx(5e-2, rel=2e-2)


def test_time_of_interpolant_nodes():
    """The interpolant evaluates the nodal controls at the node true anomalies (padding inert)."""
    sol = solve(mei2010.problem(), lgl(17), method="stm", throw=False)
    ci = sol.trajectory.flight_control()
    vals = jax.vmap(ci)(sol.stats["node_f"])
    np.testing.assert_allclose(vals, sol.node_controls, rtol=1e-12, atol=1e-18)
    t = time_from_true_anomaly(sol.problem.orbit, sol.stats["node_f"])
    np.testing.assert_allclose(t, sol.times, rtol=1e-12)
    # and the solution's own evaluation in time returns them too
    np.testing.assert_allclose(sol.controls(sol.times), sol.node_controls, rtol=1e-9,
                               atol=1e-15)


def test_plan_error_on_padded_grids_equals_the_solution_s_own_states():
    """`fly` evaluates the plan of a concrete LGL solution on its grid padded to 129 points
    (`Collocated.padded`: one program for every grid and law up to it): the plan error
    equals the largest difference between the flown states and the solution's own states
    at the flight's times. Padding adds only zero-weighted points to the barycentric sums,
    which `barycentric_interpolate` skips: equal to 1e-12 relative (round-off)."""
    import importlib

    from jaxlpm import compilation
    from jaxlpm.verify import fly

    largest_difference = importlib.import_module("jaxlpm.verify.fly")._largest_difference
    before = len(compilation.events)
    for n, law in [(9, "kkt"), (33, "stm")]:
        sol = solve(mei2010.problem(), lgl(n), method=law, throw=False)
        flight = fly(sol)
        want = np.asarray(largest_difference(flight.states, sol.states(flight.times)))
        np.testing.assert_allclose(flight.plan_error, want, rtol=1e-12)
    plans = [e for e in compilation.events[before:] if e["name"].endswith("_plan_difference")]
    assert len(plans) <= 1


def test_vmapped_j2_flight_flags_a_nan_orbit():
    """A NaN inclination (traced: no Python check sees it) in a vmapped J2 flight: a failed status for
    that member, the other as if flown alone. Members take their own adaptive steps and
    vectorisation only reorders rounding, so 1e-12 (the integrator's tolerance) relative to
    the largest component bounds the difference; diffrax's default throw=True raised here."""
    T = 1000.0
    ci = zero_control(ORBIT.f0, true_anomaly_from_time(ORBIT, T))
    fly = lambda i: propagate_nonlinear(ORBIT.replace(i=i), X0, T, ci, 2, J2_EARTH)[1:]
    incl = jnp.array([0.5, jnp.nan])
    xs, status = jax.jit(jax.vmap(fly))(incl)
    assert (np.asarray(status) == Status.SUCCESS).tolist() == [True, False]
    alone, status_alone = jax.jit(fly)(incl[0])
    assert int(status_alone) == Status.SUCCESS
    assert float(jnp.max(jnp.abs(xs[0] - alone)) / jnp.max(jnp.abs(alone))) < 1e-12


def test_shooting_returns_the_integrators_status():
    """Guesses whose flow cannot be integrated give a status, not an exception: a NaN costate
    (NONFINITE, the flow skipped) and a duration of ~1e6 revolutions (MAX_ITERATIONS: the
    100 000-step limit)."""
    orbit = KeplerOrbit(a=jnp.asarray(7000e3), e=jnp.asarray(0.0))
    prob = MinimumTimeTransfer(orbit, jnp.zeros(6), jnp.array([5.0, 30.0, -3.0, 0.0, 0.5, 0.0]),
                               jnp.asarray(1.0), jnp.asarray(200.0), jnp.asarray([0.0, jnp.inf]))
    shoot = jax.jit(lambda lam, t: min_time_shooting(prob, lam, t))
    lam = jnp.array([0.0, 0.0, 0.0, 0.0, -1.0, 0.0])
    nan_guess = shoot(lam.at[4].set(jnp.nan), 100.0)
    assert int(nan_guess.status) == Status.NONFINITE
    long_guess = shoot(lam, 1e6 * float(orbit.period))
    assert int(long_guess.status) == Status.MAX_ITERATIONS


_X64_OFF = """
import jax.numpy as jnp
from jaxlpm import KeplerOrbit, MinimumTimeTransfer
from jaxlpm.solution import PAD_TO, ControlInterpolant
from jaxlpm.verify import min_time_shooting, propagate_linear, propagate_nonlinear
from jaxlpm.verify.inertial import fly
orbit = KeplerOrbit(a=jnp.asarray(7e6), e=jnp.asarray(0.1))
control = ControlInterpolant(jnp.full(PAD_TO, 10.0).at[0].set(0.0),
                             jnp.zeros(PAD_TO).at[0].set(1.0), jnp.zeros((PAD_TO, 3)),
                             orbit.f0, orbit.f0 + 0.1, variable="anomaly")
x0 = jnp.array([100.0, 0.0, 0.0, 0.0, 0.0, 0.0])
problem = MinimumTimeTransfer(orbit, jnp.zeros(6), x0, jnp.asarray(1.0), jnp.asarray(200.0))
calls = [lambda: propagate_linear(orbit, x0, 100.0, control, 3),
         lambda: propagate_nonlinear(orbit, x0, 100.0, control, 3),
         lambda: fly(jnp.array([7e6, 0.0, 0.0, 0.0, 7.5e3, 0.0]), 800.0, 0.0, 100.0),
         lambda: min_time_shooting(problem, jnp.ones(6), 100.0)]
for call in calls:
    try:
        call()
        print("no error")
    except ValueError as err:
        print("ValueError", "float64" in str(err))
"""


def test_verify_entry_points_refuse_float32():
    """With float64 off (a fresh process: toggling x64 here would break the other tests) the
    public verify functions raise jaxlpm's ValueError before integrating in float32."""
    env = {k: v for k, v in os.environ.items() if k != "JAX_ENABLE_X64"}
    out = subprocess.run([sys.executable, "-c", _X64_OFF], capture_output=True, text=True,
                         env=env, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split("\n")[:4] == ["ValueError True"] * 4, out.stdout


def test_reproduce_mei2010(tmp_path):
    from jaxlpm.cli import main

    out = tmp_path / "mei"
    assert main(["reproduce", "mei2010", "--json", str(tmp_path / "r.json"), "--out", str(out)]) == 0
    r = json.loads((tmp_path / "r.json").read_text())
    c = r["computed"]
    assert r["schema_version"] == 1 and r["case"] == "mei2010"
    # Acceptance: the N = 64 interpolated control leaves < 1 mm on the linear model, both laws.
    for law in ("stm", "kkt"):
        assert c["terminal_error_linear"][law][0] < 1e-3
        # On the nonlinear model the linearisation error dominates: metres, not millimetres.
        assert c["terminal_error_nonlinear"][law][0] > 1.0
    # The two laws converge to one optimum (spectral: agreement to 1e-8 by N = 96).
    last = c["convergence"][-1]
    assert abs(last["J_stm"] - last["J_kkt"]) / last["J_kkt"] < 1e-8
    # Mei eq. (8) is k^2 times the time-domain energy.
    assert c["J_kkt"] == pytest.approx(c["J_time_kkt"] * float(mei2010.problem().orbit.k2), rel=1e-12)
    # Issue 3 acceptance: the Newton-KKT transfers on the nonlinear models (two-body; J2 on
    # both spacecraft), flown through those models by Dopri8, miss by well under 1 m (the
    # linear laws: hundreds of metres). 0.1 m / 1e-4 m/s sit 10x above the measured
    # millimetres, which the N = 64 discretisation error sets.
    for key in ("nonlinear_transfer", "nonlinear_j2_transfer"):
        t = c[key]
        # converged; INACCURATE at 65 points by the default tolerance (issue 19: the
        # polynomial strays ~0.1 m from its own flight between the nodes while its end lands
        # within millimetres), which the estimate in the same row says
        assert t["status"] in ("SUCCESS", "INACCURATE") and 1 <= t["iterations"] <= 10
        assert (t["status"] == "SUCCESS") == (t["error_estimate"][0] <= 0.1
                                              and t["error_estimate"][1] <= 1e-4)
        assert t["terminal_error_nonlinear"][0] < 0.1 and t["terminal_error_nonlinear"][1] < 1e-4
    # the nonlinear optimum differs from the linear one by the linearisation's O(|x|/r) ~ 1e-3
    assert 1e-4 < abs(c["nonlinear_transfer"]["J"] / c["J_kkt"] - 1.0) < 0.05
    for name in ("fig1_control_stm", "fig2_linear_stm", "fig3_nonlinear_stm", "fig4_control_kkt",
                 "fig5_linear_kkt", "fig6_nonlinear_kkt", "convergence", "newton_two-body_control",
                 "newton_two-body_flight", "newton_j2_control", "newton_j2_flight"):
        assert (out / f"{name}.png").stat().st_size > 10_000
