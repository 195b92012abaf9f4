"""Design under uncertainty (`jaxlpm.design`, issue 23): the risk measures against NumPy, the
gradient of the risk measure with respect to theta against central finite differences under
common random numbers (linear model by the KKT law, two-body by Newton-KKT), failed members
left out of the statistic, the bounds, resuming a run, and the brute force's cells against the
optimiser's own evaluation."""

import jax
import jax.numpy as jnp
import numpy as np
import optax
import pytest

import jaxlpm as lpm
from jaxlpm.design import cvar, mean, mean_std

CHIEF = lpm.KeplerOrbit(a=9500e3, e=0.3, i=np.radians(30), raan=np.radians(30),
                        argp=np.radians(10))
X0 = jnp.array([10e3, 10e3, 0.0, 4.0, -23.485, 0.0])
SPREAD = jnp.array([2e3, 2e3, 2e3, 1.0, 1.0, 1.0])
KEY = jax.random.key(7)
THETA = {"periods": 1.5, "f0": 1.0}


def make_dispersion(samples, model="linear", invalid_first=False):
    def dispersion(key, theta):
        dx = SPREAD * jax.random.uniform(key, (samples, 6), minval=-1.0, maxval=1.0)
        orbit = CHIEF.replace(f0=theta["f0"])
        duration = theta["periods"] * CHIEF.period * jnp.ones(samples)
        if invalid_first:                     # a negative duration: INVALID_INPUT
            duration = duration.at[0].set(-1.0)
        return jax.vmap(lambda d, T: lpm.EnergyOptimalTransfer(
            orbit, X0 + d, jnp.zeros(6), T, model=model))(dx, duration)
    return dispersion


def make_design(samples=4, model="linear", points=33, invalid_first=False, label="test",
                risk=mean_std(2.0)):
    return lpm.design.DesignProblem(
        make_dispersion(samples, model, invalid_first), lower={"periods": 1.0, "f0": 0.0},
        upper={"periods": 4.0, "f0": 2 * np.pi}, risk=risk, grid=lpm.lgl(points), label=label)


@pytest.fixture(scope="module")
def linear_design():
    return make_design()


def test_risk_measures_against_numpy():
    rng = np.random.default_rng(0)
    x = rng.normal(size=50)
    w = np.zeros(50)
    w[rng.permutation(50)[:40]] = 1.0               # 40 counted members
    counted = x[w > 0]
    # exact formulas: agreement to round-off of a 50-term sum
    assert float(mean()(x, w)) == pytest.approx(counted.mean(), rel=1e-13)
    assert float(mean_std(2.0)(x, w)) == pytest.approx(counted.mean() + 2 * counted.std(),
                                                       rel=1e-13)
    worst = np.sort(counted)[-8:]                     # the worst 20 % of 40: 8 members
    assert float(cvar(0.8)(x, w)) == pytest.approx(worst.mean(), rel=1e-13)
    # d CVaR / dx: 1/8 on each of the worst 8, 0 elsewhere (the quantile held fixed)
    g = np.asarray(jax.grad(cvar(0.8))(jnp.asarray(x), jnp.asarray(w)))
    expected = np.where((w > 0) & (x >= worst.min()), 1 / 8, 0.0)
    np.testing.assert_allclose(g, expected, atol=1e-15)
    with pytest.raises(ValueError, match="level"):
        cvar(1.0)


def _fd(design, theta, name, h):
    up = dict(theta, **{name: theta[name] + h})
    down = dict(theta, **{name: theta[name] - h})
    return (float(lpm.design.evaluate(design, up, KEY)["objective"])
            - float(lpm.design.evaluate(design, down, KEY)["objective"])) / (2 * h)


def test_gradient_matches_central_differences_linear(linear_design):
    """The KKT law is a linear solve, its delta-v a quadrature: smooth in theta. h = 1e-5
    (periods, rad): truncation ~h^2 ~ 1e-10 relative, round-off ~1e-13 / h = 1e-8; 1e-6
    asserted."""
    ev = lpm.design.evaluate(linear_design, THETA, KEY)
    assert np.all(np.asarray(ev["status"]) == lpm.Status.SUCCESS)
    for name in THETA:
        assert float(ev["gradient"][name]) == pytest.approx(
            _fd(linear_design, THETA, name, 1e-5), rel=1e-6), name


def test_gradient_matches_central_differences_two_body():
    """Newton-KKT on the two-body model, differentiated by the implicit function theorem.
    The solves converge to ~1e-12 in the scaled unknowns, so with h = 1e-4 the differences
    carry ~1e-8 relative noise plus ~h^2 truncation; 1e-5 asserted."""
    design = make_design(samples=2, model="two-body", points=33)
    ev = lpm.design.evaluate(design, THETA, KEY)
    assert np.all(np.asarray(ev["status"]) == lpm.Status.SUCCESS)
    for name in THETA:
        assert float(ev["gradient"][name]) == pytest.approx(_fd(design, THETA, name, 1e-4),
                                                            rel=1e-5), name
    result = lpm.design.optimise(design, THETA, KEY, steps=2, common_random_numbers=True,
                                 progress=False)
    # step 1 warm-started from step 0's solutions: converged like a cold start
    assert [h["success"] for h in result.history] == [2, 2]


def test_failed_members_are_left_out():
    design = make_design(samples=4, invalid_first=True)
    ev = lpm.design.evaluate(design, THETA, KEY)
    status, q = np.asarray(ev["status"]), np.asarray(ev["quantity"])
    assert status[0] == lpm.Status.INVALID_INPUT and np.all(status[1:] == lpm.Status.SUCCESS)
    assert float(ev["objective"]) == pytest.approx(q[1:].mean() + 2 * q[1:].std(), rel=1e-13)
    assert all(np.isfinite(float(g)) for g in ev["gradient"].values())
    result = lpm.design.optimise(design, THETA, KEY, steps=1, progress=False)
    assert result.history[0]["failed"] == {"INVALID_INPUT": 1}
    assert result.history[0]["success"] == 3


def test_bounds_and_resume(linear_design, tmp_path):
    """A huge SGD step lands on the box's faces (projection); a run stopped after 2 steps and
    restarted for 3 continues from its saved state and matches an uninterrupted run."""
    sgd = optax.sgd(1e6)
    kwargs = dict(optimizer=sgd, common_random_numbers=False, progress=False)
    first = lpm.design.optimise(linear_design, THETA, KEY, steps=2, out=tmp_path / "a",
                                **kwargs)
    for h in first.history[1:]:
        assert h["theta"]["periods"] in (1.0, 4.0) and h["theta"]["f0"] in (0.0, 2 * np.pi)
    resumed = lpm.design.optimise(linear_design, THETA, KEY, steps=3, out=tmp_path / "a",
                                  **kwargs)
    whole = lpm.design.optimise(linear_design, THETA, KEY, steps=3, out=tmp_path / "b",
                                **kwargs)
    assert len(resumed.history) == 3 and resumed.history[:2] == first.history[:2]
    for r, w in zip(resumed.history, whole.history):
        assert r["theta"] == w["theta"] and r["objective"] == pytest.approx(w["objective"],
                                                                            rel=1e-12)
    assert (tmp_path / "a" / "history.json").is_file()
    other = make_design(label="another dispersion")
    with pytest.raises(ValueError, match="another definition"):
        lpm.design.optimise(other, THETA, KEY, steps=3, out=tmp_path / "a", **kwargs)


def test_brute_force_cells_equal_the_optimisers_evaluation(linear_design, tmp_path):
    """The brute force (the sweep engine) and `evaluate` solve the same samples at the same
    theta: the same objective to round-off (the KKT law is deterministic), the same SUCCESS
    members (2 periods on lgl(33) are INACCURATE: no statistic, NaN, in both)."""
    axes = {"periods": np.array([1.5, 2.0]), "f0": np.array([0.0, 1.0])}
    brute = lpm.design.brute_force(linear_design, KEY, axes, out=tmp_path, progress=False)
    assert brute.objective.shape == (2, 2) and brute.solves == 16
    for i, periods in enumerate(axes["periods"]):
        for j, f0 in enumerate(axes["f0"]):
            ev = lpm.design.evaluate(linear_design, {"periods": periods, "f0": f0}, KEY)
            assert brute.objective[i, j] == pytest.approx(float(ev["objective"]), rel=1e-10,
                                                          nan_ok=True)
            assert brute.success[i, j] == int(np.sum(ev["status"] == lpm.Status.SUCCESS))
    assert np.isfinite(brute.objective).sum() == 2
    assert brute.argmin == {k: float(v[i]) for (k, v), i in zip(
        axes.items(), np.unravel_index(np.nanargmin(brute.objective), (2, 2)))}
