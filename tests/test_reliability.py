"""Failure modes found by the bad-input battery of issue 17: reduced actuation (defect 1),
validation of every orbit field (defect 4) and the smaller ones (defect 8)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxlpm as lpm
from jaxlpm.batch import transfer_family
from jaxlpm.constants import MU_EARTH, R_EARTH
from jaxlpm.status import Status

# small grids for speed: solutions that converge unresolved are accepted (conftest)
pytestmark = pytest.mark.usefixtures("loose_accuracy")

ORBIT = lpm.KeplerOrbit(a=9500e3, e=0.3)
X0 = jnp.array([10e3, 10e3, 0.0, 4.0, -23.485, 0.0])     # mei2010's chaser, in-plane
PLANAR = (True, True, False)
RADIAL_ONLY = (True, False, True)
GRID = lpm.lgl(17)
LAWS = ("stm", "kkt", "newton")


def transfer(x0=X0, axes=(True, True, True), orbit=ORBIT, model="linear", revolutions=1.0):
    return lpm.EnergyOptimalTransfer.from_revolutions(orbit, x0, jnp.zeros(6), revolutions,
                                                      thrust_axes=axes, model=model)


# ---- defect 1: reduced actuation -------------------------------------------------------------

@pytest.mark.parametrize("method", LAWS)
def test_planar_thrust_on_an_in_plane_transfer_is_the_full_thrust_optimum(method):
    """With z0 = zf = 0 the out-of-plane motion is zero with or without z thrust, so the planar
    optimum is the full-thrust one (the blocks decouple on the linear model): same cost to the
    laws' round-off (measured ~1e-13 relative), status SUCCESS, no exception."""
    planar = lpm.solve(transfer(axes=PLANAR), GRID, method=method)
    full = lpm.solve(transfer(), GRID, method=method)
    assert planar.message == Status.SUCCESS.message
    np.testing.assert_allclose(float(planar.cost), float(full.cost), rtol=1e-9)


def test_planar_thrust_solution_flies_to_the_target():
    """The planar KKT solution's own interpolated control, flown on the linear model, reaches
    the target like the full-thrust one (lgl(17) over one revolution: metres, not km)."""
    prob = transfer(axes=PLANAR)
    sol = lpm.solve(prob, GRID, method="kkt")
    full = lpm.solve(transfer(), GRID, method="kkt")
    misses = []
    for s in (sol, full):
        flight = lpm.verify.fly(s)
        assert bool(flight.success)
        misses.append(float(flight.terminal_error[0]))
    assert abs(misses[0] - misses[1]) <= 1e-6 * max(misses[1], 1.0)
    assert float(jnp.max(jnp.abs(sol.node_controls[:, 2]))) == 0.0     # no z thrust at all


@pytest.mark.parametrize("method", LAWS)
def test_unreachable_out_of_plane_target_is_singular(method):
    """z0 = 100 m, zf = 0 without z thrust: the free drift cannot reach the target (the
    out-of-plane motion is a free oscillation), so SINGULAR, never an exception or SUCCESS."""
    with pytest.raises(lpm.SolveError, match="SINGULAR"):
        lpm.solve(transfer(x0=X0.at[2].set(100.0), axes=PLANAR), GRID, method=method)
    sol = lpm.solve(transfer(x0=X0.at[2].set(100.0), axes=PLANAR), GRID, method=method,
                    throw=False)
    assert int(sol.status) == Status.SINGULAR


@pytest.mark.parametrize("e", [0.0, 0.3])
@pytest.mark.parametrize("method", LAWS)
def test_radial_thrust_alone_is_singular(method, e):
    """In-plane relative motion is not controllable by radial thrust alone (HCW: the
    along-track drift rate is out of its reach; TH likewise, the Gramian is singular): the
    along-track offset of mei2010's case is not reachable, status SINGULAR."""
    orbit = ORBIT.replace(e=e)
    sol = lpm.solve(transfer(orbit=orbit, axes=RADIAL_ONLY), GRID, method=method, throw=False)
    assert int(sol.status) == Status.SINGULAR


@pytest.mark.parametrize("method", LAWS)
def test_along_track_thrust_alone_reaches_the_target(method):
    """Along-track thrust alone controls in-plane HCW/TH motion: SUCCESS, and the optimum
    with fewer axes cannot cost less than with all of them."""
    sol = lpm.solve(transfer(axes=(False, True, True)), GRID, method=method)
    full = lpm.solve(transfer(), GRID, method=method)
    assert int(sol.status) == Status.SUCCESS
    assert float(sol.cost) >= float(full.cost) * (1.0 - 1e-12)


@pytest.mark.parametrize("scheme", [lpm.lgr(16), lpm.lg(16)])
def test_planar_thrust_newton_on_lg_and_lgr(scheme):
    """The Newton solver's redundant out-of-plane constraints (no z control) are consistent,
    so it converges on every scheme; the unreachable case is SINGULAR."""
    ok = lpm.solve(transfer(axes=PLANAR), scheme, method="newton")
    bad = lpm.solve(transfer(x0=X0.at[2].set(100.0), axes=PLANAR), scheme, method="newton",
                    throw=False)
    assert int(ok.status) == Status.SUCCESS
    assert int(bad.status) == Status.SINGULAR


def test_planar_thrust_batched_kkt_law():
    """Vmapped over e with planar thrust: every member SUCCESS, finite costs."""
    es = jnp.array([0.0, 0.2, 0.5])
    prob = transfer(axes=PLANAR)
    sols = jax.jit(jax.vmap(lambda e: lpm.solve(
        prob.replace(orbit=prob.orbit.replace(e=e)), GRID, method="kkt")))(es)
    assert np.all(np.asarray(sols.status) == Status.SUCCESS)
    assert np.all(np.isfinite(np.asarray(sols.cost)))


# ---- defect 4: every orbit field is validated ------------------------------------------------

BAD_ORBIT_FIELDS = [("f0", np.nan), ("f0", np.inf), ("mu", 0.0), ("mu", -1.0), ("mu", np.nan),
                    ("i", np.nan), ("raan", np.inf), ("argp", np.nan)]


@pytest.mark.parametrize("field,value", BAD_ORBIT_FIELDS)
@pytest.mark.parametrize("method", LAWS)
def test_concrete_bad_orbit_field_raises_naming_it(method, field, value):
    prob = transfer(orbit=ORBIT).replace(orbit=ORBIT.replace(**{field: value}))
    with pytest.raises(ValueError, match=f"orbit.{field}"):
        lpm.solve(prob, GRID, method=method)


@pytest.mark.parametrize("method", ["stm", "kkt"])
def test_traced_bad_orbit_fields_give_invalid_input(method):
    """Under jit/vmap a bad f0 or mu gives INVALID_INPUT with zeroed, finite outputs, and the
    good member is unchanged."""
    prob = transfer()
    f0 = jnp.array([0.0, jnp.nan, 0.0, 0.0])
    mu = jnp.array([MU_EARTH, MU_EARTH, -1.0, jnp.nan])
    sols = jax.jit(jax.vmap(lambda f, m: lpm.solve(
        prob.replace(orbit=prob.orbit.replace(f0=f, mu=m)), GRID, method=method)))(f0, mu)
    assert np.asarray(sols.status).tolist() == [Status.SUCCESS] + [Status.INVALID_INPUT] * 3
    assert np.all(np.isfinite(np.asarray(sols.cost)))
    assert np.all(np.asarray(sols.cost)[1:] == 0.0)
    np.testing.assert_allclose(float(sols.cost[0]), float(lpm.solve(prob, GRID, method=method).cost),
                               rtol=1e-12)


def test_traced_bad_orbit_field_newton():
    prob = transfer()
    sols = jax.jit(jax.vmap(lambda m: lpm.solve(
        prob.replace(orbit=prob.orbit.replace(mu=m)), GRID, method="newton")))(
            jnp.array([MU_EARTH, jnp.nan]))
    assert np.asarray(sols.status).tolist() == [Status.SUCCESS, Status.INVALID_INPUT]
    assert np.all(np.isfinite(np.asarray(sols.cost)))


def test_fuel_optimal_validates_the_orbit():
    orbit = lpm.KeplerOrbit(a=6778137.0, e=0.0, mu=np.nan)
    prob = lpm.FuelOptimalTransfer(orbit, jnp.zeros(6), jnp.array([0.0, 4e3, 0, 0, 0, 0]),
                                   3000.0, 0.05, 50.0, 1000.0)
    with pytest.raises(ValueError, match="orbit.mu"):
        prob.validate()
    assert not bool(prob.validity())


# ---- defect 8: the smaller ones --------------------------------------------------------------

def test_from_revolutions_with_a_zero_semi_major_axis_raises_value_error():
    with pytest.raises(ValueError, match="orbit.a"):
        lpm.EnergyOptimalTransfer.from_revolutions(lpm.KeplerOrbit(a=0.0, e=0.1), X0,
                                                   jnp.zeros(6), 1.0)


def test_array_likes_are_accepted_for_states():
    prob = transfer()
    as_list = prob.replace(x0=[float(v) for v in X0], xf=[0.0] * 6)
    sol = lpm.solve(as_list, GRID, method="kkt")
    assert float(sol.cost) == float(lpm.solve(prob, GRID, method="kkt").cost)
    with pytest.raises(ValueError, match="x0"):
        prob.replace(x0=["a"] * 6)


def test_perigee_rule_applies_to_the_nonlinear_models_only():
    """The nonlinear models fly the chief on its orbit and need r_p above the surface; the
    linear model is a local expansion. solve and sweep apply the same rule."""
    underground = lpm.KeplerOrbit(a=9500e3, e=0.5)          # r_p = 4750 km < R_EARTH
    assert 9500e3 * 0.5 < R_EARTH
    lpm.solve(transfer(orbit=underground), GRID, method="kkt")     # linear: allowed
    with pytest.raises(ValueError, match="perigee"):
        lpm.solve(transfer(orbit=underground, model="two-body"), GRID, method="newton")
    linear = transfer_family("mei", transfer(), method="kkt")
    nonlinear = transfer_family("mei", transfer(model="two-body"), method="newton")
    params = {"e": np.array([0.1, 0.5]), "a": np.array([9500e3, 9500e3])}
    linear.validate(params)
    with pytest.raises(ValueError, match="perigee"):
        nonlinear.validate(params)


def _captured_figure(monkeypatch):
    from jaxlpm.cases import plots
    figures = []
    monkeypatch.setattr(plots, "_save", lambda fig, path: figures.append(fig) or path)
    return plots, figures


def test_mei2010_convergence_plot_does_not_compare_the_reference_with_itself(monkeypatch):
    plots, figures = _captured_figure(monkeypatch)
    rows = [{"N": n, "J_stm": 1.0 + 1.0 / n, "J_kkt": 1.0 + 0.5 / n,
             "terminal_error_linear_stm": [1.0 / n, 0.0],
             "terminal_error_linear_kkt": [0.5 / n, 0.0]} for n in (8, 16, 128)]
    plots.plot_convergence(rows, "unused.png")
    cost_axes = figures[0].axes[0]
    for line in cost_axes.get_lines():
        assert 128 not in list(line.get_xdata())


def test_duan_mesh_study_marks_an_unconverged_point_apart(monkeypatch):
    plots, figures = _captured_figure(monkeypatch)
    rows = [{"K": k, "scheme": "LG", "tf_error": 1e-3 / k, "terminal_miss": [1.0 / k, 1e-3],
             "status": "SUCCESS" if k != 150 else "MAX_ITERATIONS"} for k in (40, 100, 150)]
    plots.plot_mesh_study(rows, [], "unused.png")
    joined = [line for line in figures[0].axes[0].get_lines() if len(line.get_xdata()) > 1]
    assert all(150 not in list(line.get_xdata()) for line in joined)
    labels = [line.get_label() for line in figures[0].axes[0].get_lines()]
    assert any("MAX_ITERATIONS" in label for label in labels)


def test_static_fields_compare_simply_for_jit():
    """jit compares static pytree metadata by equality: a grid rebuilt after its operator cache
    was cleared, and thrust axes given as a NumPy bool array, once gave "Exception raised while
    checking equality of metadata fields" on every later call of the same law (CI, issue 17)."""
    from jaxlpm.collocation.grid import _host_operators
    before = lpm.lgl(11)
    _host_operators.cache_clear()
    after = lpm.lgl(11)
    assert before.points is not after.points
    axes = np.array(PLANAR)
    costs = [float(lpm.solve(transfer(axes=a), g, method="kkt").cost)
             for g in (before, after) for a in (axes, PLANAR)]
    assert transfer(axes=axes).thrust_axes == PLANAR
    assert len(set(costs)) == 1          # one problem: the same compiled law, the same number
