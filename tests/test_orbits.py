"""Tests of jaxlpm.orbits: Kepler orbits (elements <-> state, time <-> true anomaly, Kepler's
equation and its implicit derivatives) and the relative frames (inertial <-> LVLH <-> TH).

Independent references: scipy.integrate.solve_ivp (DOP853, rtol 1e-13) for two-body motion,
scipy.integrate.quad for the time integral dt/df = 1 / (k^2 rho^2), closed-form derivatives and
finite differences. Tolerances are stated in units of EPS (float64 machine epsilon) or as
integrator / finite-difference error bounds, each with its reason next to it.
"""

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp

from jaxlpm.constants import MU_EARTH
from jaxlpm.orbits import (
    KeplerOrbit,
    eccentric_from_mean,
    eccentric_from_true,
    elements_to_state,
    inertial_to_lvlh,
    lvlh_basis,
    lvlh_to_relative_inertial,
    lvlh_to_th,
    mean_from_true,
    relative_inertial_to_lvlh,
    state_to_elements,
    th_to_lvlh,
    time_from_true_anomaly,
    true_anomaly_from_time,
    true_from_eccentric,
)

EPS = np.finfo(np.float64).eps
TWO_PI = 2.0 * np.pi
FIELDS = ("a", "e", "i", "raan", "argp", "f0")

NPAD = 2048  # every batched call is padded to this length: one compilation per function


def orbit_(a, e, i=0.0, raan=0.0, argp=0.0, f0=0.0, mu=MU_EARTH):
    """KeplerOrbit with float64 (not weakly typed) leaves, so every orbit in this file has the
    same abstract signature and each jitted function below compiles once."""
    f = np.float64
    return KeplerOrbit(a=f(a), e=f(e), i=f(i), raan=f(raan), argp=f(argp), f0=f(f0), mu=f(mu))


def with_(orbit, **kwargs):
    return orbit.replace(**{k: np.float64(v) for k, v in kwargs.items()})


def _padded(fn):
    """Batched fn(orbit, x) over 1-D x, padded to NPAD and compiled once."""
    jitted = jax.jit(fn)

    def call(orbit, x, *rest):
        x = np.atleast_1d(np.asarray(x, dtype=np.float64))
        assert x.ndim == 1 and x.size <= NPAD
        xp = np.concatenate([x, np.full(NPAD - x.size, x[-1])])
        out = jitted(orbit, xp, *rest)
        return jax.tree.map(lambda y: np.asarray(y)[: x.size], out)

    return call


_to_state = jax.jit(elements_to_state)


def to_state(orbit, f=None):
    """elements_to_state with f always a float64 scalar (one compilation)."""
    f = orbit.f0 if f is None else f
    r, v = _to_state(orbit, np.float64(f))
    return np.asarray(r), np.asarray(v)


to_elements = jax.jit(state_to_elements)
t_of_f = _padded(jax.vmap(time_from_true_anomaly, in_axes=(None, 0)))
f_of_t = _padded(jax.vmap(true_anomaly_from_time, in_axes=(None, 0)))
dfdt = _padded(jax.vmap(jax.grad(true_anomaly_from_time, argnums=1), in_axes=(None, 0)))
dtdf = _padded(jax.vmap(jax.grad(time_from_true_anomaly, argnums=1), in_axes=(None, 0)))
dfde = _padded(jax.vmap(
    jax.grad(lambda orbit, t: true_anomaly_from_time(orbit, t), argnums=0), in_axes=(None, 0)))
dtde = _padded(jax.vmap(
    jax.grad(lambda orbit, f: time_from_true_anomaly(orbit, f), argnums=0), in_axes=(None, 0)))


def _kepler_batch(M, e):
    return jax.vmap(eccentric_from_mean)(M, e), jax.vmap(jax.grad(eccentric_from_mean, (0, 1)))(M, e)


_kepler_jit = jax.jit(_kepler_batch)


def solve_kepler(M, e):
    """(E, dE/dM, dE/de) for 1-D M and e (e broadcast), padded to NPAD."""
    M = np.asarray(M, dtype=np.float64)
    e = np.broadcast_to(np.asarray(e, dtype=np.float64), M.shape)
    pad = NPAD - M.size
    E, (dM, de) = _kepler_jit(np.r_[M, np.zeros(pad)], np.r_[e, np.zeros(pad)])
    return (np.asarray(E)[: M.size], np.asarray(dM)[: M.size], np.asarray(de)[: M.size])


GENERIC = [
    orbit_(a=7.0e6, e=0.01, i=0.9, raan=4.0, argp=5.5, f0=2.5),
    orbit_(a=2.0e7, e=0.3, i=1.1, raan=0.3, argp=2.0, f0=5.9),
    orbit_(a=4.0e7, e=0.8, i=2.5, raan=3.5, argp=0.7, f0=1.2),  # retrograde
]


def _as_np(orbit):
    return np.array([float(getattr(orbit, k)) for k in FIELDS])


def _angle_diff(x, y):
    """Signed difference x - y wrapped to (-pi, pi] (angles near 0 and 2 pi are the same)."""
    return np.angle(np.exp(1j * (np.asarray(x) - np.asarray(y))))



# --------------------------------------------------------------------------------------------
# elements <-> state
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("orbit", GENERIC, ids=lambda o: f"e={float(o.e)}")
def test_elements_state_round_trip(orbit):
    for f in (0.0, 1.0, 2.5, 3.1, 4.7, 6.0):
        orb = with_(orbit, f0=f)
        back = to_elements(*to_state(orb), orb.mu)
        got, want = _as_np(back), _as_np(orb)
        # a from the vis-viva energy 2/r - v^2/mu: cancellation of two terms of size 1/a
        # amplifies rounding by (2a/r) <= 2/(1-e) = 10 at e = 0.8; 100 EPS bounds it.
        assert abs(got[0] - want[0]) <= 100 * EPS * want[0], f
        # e = |e vector|, built of terms of size ~1 each rounded to ~EPS: 1e3 EPS is loose.
        assert abs(got[1] - want[1]) <= 1e3 * EPS, f
        # Angles from atan2 of unit-vector products (~EPS), conditioned by 1/e for argp and f
        # (measured from the eccentricity vector, absolute error ~EPS): at e = 0.01 ~100 EPS
        # ~ 2e-14 rad, bounded by 1e-12 rad.
        ang = _angle_diff(got[2:], want[2:])
        assert np.all(np.abs(ang) <= 1e-12), (f, ang)
        assert 0.0 <= got[2] <= np.pi


@pytest.mark.parametrize("orbit", GENERIC, ids=lambda o: f"e={float(o.e)}")
def test_state_to_elements_angle_range(orbit):
    """Documented: raan, argp, f0 in [0, 2 pi). At periapsis (f = 0) the computed angle can be
    about -1e-17 rad, and jnp.mod(-1e-17, 2 pi) rounds to exactly 2 pi: that value is outside
    the documented half-open range and must not be returned."""
    for f in (0.0, 1e-17, -1e-17, np.pi, TWO_PI - 1e-15):
        got = _as_np(to_elements(*to_state(with_(orbit, f0=f)), orbit.mu))
        assert np.all((got[3:] >= 0.0) & (got[3:] < TWO_PI)), (f, got[3:] - TWO_PI)


def test_elements_to_state_values():
    """elements_to_state against the perifocal formula written out by hand."""
    a, e, f = 2.0e7, 0.3, 0.8
    p = a * (1 - e**2)
    rn = p / (1 + e * np.cos(f))
    # raan = pi/2, i = pi/2, argp = 0: the node line is the y axis, P = (0, 1, 0),
    # Q = (0, 0, 1), orbit normal W = (sin raan sin i, -cos raan sin i, cos i) = (1, 0, 0).
    r, v = to_state(orbit_(a=a, e=e, i=np.pi / 2, raan=np.pi / 2, argp=0.0, f0=f))
    r_want = rn * np.array([0.0, np.cos(f), np.sin(f)])
    v_want = np.sqrt(MU_EARTH / p) * np.array([0.0, -np.sin(f), e + np.cos(f)])
    # A few roundings of cos/sin (cos(pi/2) = 6e-17 leaks into the zero entries) and
    # products: 10 EPS of the vector's size.
    np.testing.assert_allclose(r, r_want, rtol=0, atol=10 * EPS * rn)
    np.testing.assert_allclose(v, v_want, rtol=0, atol=10 * EPS * np.linalg.norm(v_want))
    # Energy v^2/2 - mu/r = -mu/(2a): cancellation of terms ~mu/r <= 10 mu/(2a) -> 100 EPS.
    energy = np.dot(v, v) / 2 - MU_EARTH / np.linalg.norm(r)
    assert abs(energy + MU_EARTH / (2 * a)) <= 100 * EPS * MU_EARTH / a
    # |h| = sqrt(mu p): products of EPS-accurate numbers, 10 EPS.
    h = np.linalg.norm(np.cross(r, v))
    assert abs(h - np.sqrt(MU_EARTH * p)) <= 10 * EPS * np.sqrt(MU_EARTH * p)


@pytest.mark.parametrize(
    "elements, expected",
    [
        # circular, inclined: argp = 0 and f is the argument of latitude argp + f from the node
        (dict(e=0.0, i=0.7, raan=1.0, argp=2.0, f0=0.5),
         dict(e=0.0, i=0.7, raan=1.0, argp=0.0, f0=2.5)),
        # equatorial prograde, elliptic: raan = 0, argp is the longitude of periapsis raan + argp
        (dict(e=0.2, i=0.0, raan=1.0, argp=2.0, f0=0.5),
         dict(e=0.2, i=0.0, raan=0.0, argp=3.0, f0=0.5)),
        # equatorial retrograde: raan = 0, argp from the x axis measured about h = -z, which
        # is argp - raan
        (dict(e=0.2, i=np.pi, raan=1.0, argp=2.0, f0=0.5),
         dict(e=0.2, i=np.pi, raan=0.0, argp=1.0, f0=0.5)),
        # circular equatorial: raan = argp = 0, f is the true longitude from the x axis
        (dict(e=0.0, i=0.0, raan=1.0, argp=2.0, f0=0.5),
         dict(e=0.0, i=0.0, raan=0.0, argp=0.0, f0=3.5)),
        # circular, equatorial retrograde: longitude measured about h = -z
        (dict(e=0.0, i=np.pi, raan=1.0, argp=2.0, f0=0.5),
         dict(e=0.0, i=np.pi, raan=0.0, argp=0.0, f0=1.5)),
        # circular equatorial with raan + argp + f > 2 pi: wrapped into [0, 2 pi)
        (dict(e=0.0, i=0.0, raan=3.0, argp=3.0, f0=1.0),
         dict(e=0.0, i=0.0, raan=0.0, argp=0.0, f0=7.0 - TWO_PI)),
    ],
    ids=["circular", "equatorial", "equatorial-retro", "circ-equatorial",
         "circ-equatorial-retro", "circ-equatorial-wrap"],
)
def test_state_to_elements_conventions(elements, expected):
    orbit = orbit_(a=7.0e6, **elements)
    r, v = to_state(orbit)
    back = to_elements(r, v, orbit.mu)
    # e = 0 comes back as |e vector| ~ a few EPS (terms of size ~1 cancel): 1e-14.
    assert abs(float(back.e) - expected["e"]) <= 1e-14
    assert abs(float(back.a) - 7.0e6) <= 100 * EPS * 7.0e6  # vis-viva, as in the round trip
    # i = arccos(h_z/|h|) is sqrt-conditioned at i = 0 or pi: an EPS error in h_z/|h| gives
    # sqrt(2 EPS) ~ 2e-8 rad; 3e-8 bounds it.
    assert abs(float(back.i) - expected["i"]) <= 3e-8
    for k in ("raan", "argp", "f0"):
        got = float(getattr(back, k))
        assert 0.0 <= got < TWO_PI
        # atan2 of EPS-accurate unit-vector products: ~EPS rad; 1e-13 leaves room.
        assert abs(_angle_diff(got, expected[k])) <= 1e-13, (k, got, expected[k])
    # Whatever the convention, the elements reproduce the state: angle errors <= 1e-13 rad
    # (above) times |r| and |v| -> 1e-12 relative.
    r2, v2 = to_state(back)
    np.testing.assert_allclose(r2, r, rtol=0, atol=1e-12 * np.linalg.norm(r))
    np.testing.assert_allclose(v2, v, rtol=0, atol=1e-12 * np.linalg.norm(v))


# --------------------------------------------------------------------------------------------
# anomalies, time <-> true anomaly
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("e", [0.0, 0.1, 0.5, 0.9, 0.99])
def test_anomaly_conversions_consistent(e):
    f = np.linspace(-TWO_PI, 6 * np.pi + 1.0, 401)
    E = np.asarray(eccentric_from_true(f, e))
    # The half-angle relation tan(E/2) = sqrt((1-e)/(1+e)) tan(f/2) wherever tan is finite:
    # tan amplifies the ~EPS |E| error of E/2 by 1/cos^2(E/2) <= 1e6 near the excluded
    # poles, so ~1e-9 relative.
    ok = np.abs(np.cos(f / 2)) > 1e-3
    lhs = np.tan(E[ok] / 2)
    rhs = np.sqrt((1 - e) / (1 + e)) * np.tan(f[ok] / 2)
    np.testing.assert_allclose(lhs, rhs, rtol=1e-9, atol=1e-12)
    # Continuous: same revolution count (|E - f| < pi) and strictly increasing.
    assert np.all(np.abs(E - f) < np.pi)
    assert np.all(np.diff(E) > 0)
    # true_from_eccentric inverts it: df/dE <= sqrt((1+e)/(1-e)) ~ 14 at e = 0.99, on
    # |f| <= 20 (EPS |f| ~ 4e-15): 1e-12 rad.
    np.testing.assert_allclose(np.asarray(true_from_eccentric(E, e)), f, rtol=0, atol=1e-12)
    # M = E - e sin E: the same expression, up to a few roundings of size |E| <= 20.
    M = np.asarray(mean_from_true(f, e))
    np.testing.assert_allclose(M, E - e * np.sin(E), rtol=0, atol=50 * EPS)


ORBITS_T = [orbit_(a=2.0e7, e=e, f0=f0) for e in (0.0, 0.3, 0.7, 0.9) for f0 in (0.0, 2.0)]


@pytest.mark.parametrize("orbit", ORBITS_T, ids=lambda o: f"e={float(o.e)},f0={float(o.f0)}")
def test_time_true_anomaly_round_trip(orbit):
    f = np.linspace(-TWO_PI, 6 * np.pi + 1.0, 1001)
    f2 = f_of_t(orbit, t_of_f(orbit, f))
    # M carries a rounding of ~EPS |M| <= 5e-15 (|M| <= 20); df/dM = rho^2/(1-e^2)^1.5 <= 44
    # at e = 0.9, so 2e-13 rad; 1e-12 leaves a margin of 5.
    np.testing.assert_allclose(f2, f, rtol=0, atol=1e-12)
    # ... and the other way round, on a time grid covering -1 .. 3.2 periods.
    T = float(orbit.period)
    tt = np.linspace(-T, 3.2 * T, 777)
    t2 = t_of_f(orbit, f_of_t(orbit, tt))
    # dt/dM = 1/n = T/(2 pi); M rounded to a few EPS |M| (|M| <= 25): 1e-13 T.
    np.testing.assert_allclose(t2, tt, rtol=0, atol=1e-13 * T)


@pytest.mark.parametrize("orbit", ORBITS_T, ids=lambda o: f"e={float(o.e)},f0={float(o.f0)}")
def test_time_true_anomaly_continuous(orbit):
    T = float(orbit.period)
    f0 = float(orbit.f0)
    # t(f0) = 0, and each revolution takes exactly one period: no wrap at 2 pi.
    ks = np.arange(-1, 4)
    t = t_of_f(orbit, f0 + TWO_PI * ks)
    # Differences of M values of size <= 25 rounded to a few EPS, times 1/n = T / (2 pi):
    # 1e-14 T.
    np.testing.assert_allclose(t, ks * T, rtol=0, atol=1e-14 * T)
    # Kepler solve at M = M0 + 2 pi k exact to EPS |M|, times df/dM <= 44 (e = 0.9): 1e-12 rad.
    np.testing.assert_allclose(f_of_t(orbit, ks * T), f0 + TWO_PI * ks, rtol=0, atol=1e-12)
    # Strictly increasing on grids crossing several multiples of pi, both ways.
    f = np.linspace(f0 - 7.0, f0 + 6 * np.pi + 1.0, 2001)
    assert np.all(np.diff(t_of_f(orbit, f)) > 0)
    tt = np.linspace(-1.3 * T, 3.3 * T, 2001)
    ff = f_of_t(orbit, tt)
    assert np.all(np.diff(ff) > 0)
    # No jumps: every step is below max f_dot * dt, f_dot <= k2 (1+e)^2 (a chord's slope is
    # at most the largest slope; 1 % margin for rounding).
    max_step = float(orbit.k2) * (1 + float(orbit.e)) ** 2 * (tt[1] - tt[0])
    assert np.max(np.diff(ff)) <= 1.01 * max_step


@pytest.mark.parametrize("e", [0.0, 0.3, 0.9])
@pytest.mark.parametrize("f0", [0.0, 2.0])
def test_time_from_true_anomaly_quadrature(e, f0):
    orbit = orbit_(a=2.0e7, e=e, f0=f0)
    k2 = float(orbit.k2)
    f_end = np.array([f0 - 2.0, f0 + 0.5, f0 + 3.0, f0 + 6.5, 6 * np.pi + 1.0])
    t = t_of_f(orbit, f_end)

    def integrand(f):  # k2 dt/df = 1 / rho^2 (dimensionless)
        return 1.0 / (1.0 + e * np.cos(f)) ** 2

    for fe, te in zip(f_end, t):
        lo, hi = min(f0, fe), max(f0, fe)
        # Break at every apoapsis (odd multiples of pi), where 1/rho^2 peaks (100 at e = 0.9).
        pts = [x for x in np.pi * (2 * np.arange(-3, 6) + 1) if lo < x < hi]
        val, err = quad(integrand, lo, hi, points=pts or None, epsabs=0.0, epsrel=1e-13,
                        limit=500)
        ref = np.sign(fe - f0) * val / k2
        # quad's error estimate is ~1e-13 relative; the closed form carries a few EPS on M
        # of size <= 25 over a difference of M of size >= 0.1: 1e-12 relative bounds both.
        assert abs(err) <= 1e-12 * val
        assert abs(te - ref) <= 1e-12 * abs(ref), (fe, te, ref)


# --------------------------------------------------------------------------------------------
# Kepler's equation
# --------------------------------------------------------------------------------------------


def _random_kepler_inputs():
    rng = np.random.default_rng(20240611)
    M = np.concatenate([
        rng.uniform(-np.pi, np.pi, 300),
        rng.uniform(-200.0, 200.0, 300),          # tens of revolutions
        rng.uniform(-1e5, 1e5, 200),              # ~1e4 revolutions
        [0.0, 1e-12, -1e-12, np.pi, -np.pi, 2 * np.pi, 1e-3, 100 * np.pi + 1e-9],
    ])
    e = np.concatenate([rng.uniform(0.0, 0.99, M.size - 40), np.full(40, 0.99)])
    rng.shuffle(e)
    return M, e


def test_kepler_residual_machine_precision():
    M, e = _random_kepler_inputs()
    E, _, _ = solve_kepler(M, e)
    res = E - e * np.sin(E) - M
    # The residual is a difference of numbers of size |M|, each rounded to ~EPS max(1, |M|)
    # (E itself, e sin E, the reduction by 2 pi round(M / 2 pi)): 4 EPS max(1, |M|) is
    # machine precision.
    bound = 4 * EPS * np.maximum(1.0, np.abs(M))
    assert np.all(np.abs(res) <= bound), np.max(np.abs(res) / bound)
    # The right branch, never wrapped: |E - M| = |e sin E| <= e.
    assert np.all(np.abs(E - M) <= e + bound)


@pytest.mark.parametrize("e", [0.0, 0.5, 0.9, 0.99])
def test_kepler_monotonic_and_inverse(e):
    M = np.linspace(-15.0, 40.0, 2001)
    E, _, _ = solve_kepler(M, e)
    assert np.all(np.diff(E) > 0)
    # M -> E -> f -> M through mean_from_true o true_from_eccentric: each step rounds to ~EPS
    # |M| (|M| <= 40, ~1e-14); E -> f -> E can amplify by (1+e)/(1-e) ~ 200 at e = 0.99 near
    # periapsis: ~2e-12, bounded by 1e-11.
    f = np.asarray(true_from_eccentric(E, e))
    np.testing.assert_allclose(np.asarray(mean_from_true(f, e)), M, rtol=0, atol=1e-11)


def test_kepler_gradients_implicit():
    M, e = _random_kepler_inputs()
    E, dM, de = solve_kepler(M, e)
    # Implicit function theorem on E - e sin E - M = 0: dE/dM = 1/(1 - e cos E),
    # dE/de = sin E / (1 - e cos E). The same formula evaluated two ways at the same E:
    # rounding ~EPS times 1/(1 - e cos E) <= 100, so 1e-12 of the 1/(1 - e cos E) scale.
    denom = 1.0 - e * np.cos(E)
    np.testing.assert_allclose(dM, 1.0 / denom, rtol=1e-12)
    assert np.all(np.abs(de - np.sin(E) / denom) <= 1e-12 / denom)


@pytest.mark.parametrize("e", [0.0, 0.3, 0.7, 0.9, 0.99])
def test_grad_true_anomaly_wrt_time_closed_form(e):
    orbit = orbit_(a=2.0e7, e=e, f0=0.7)
    T = float(orbit.period)
    t = np.linspace(-1.2 * T, 3.4 * T, 57)
    g = dfdt(orbit, t)
    f = f_of_t(orbit, t)
    # f_dot = k^2 rho^2 (h = r^2 f_dot), evaluated with f from the same solve: rounding
    # ~10 EPS relative, times the chain rule's conditioning 1/(1 - e cos E) <= 100 -> 1e-12;
    # 1e-10 is loose.
    want = float(orbit.k2) * (1 + e * np.cos(f)) ** 2
    np.testing.assert_allclose(g, want, rtol=1e-10)


@pytest.mark.parametrize("e", [0.1, 0.5, 0.8])
def test_grad_true_anomaly_wrt_time_finite_differences(e):
    orbit = orbit_(a=2.0e7, e=e, f0=0.7)
    n, T = float(orbit.mean_motion), float(orbit.period)
    t = np.linspace(-1.2 * T, 3.4 * T, 23)
    g = dfdt(orbit, t)
    # Central difference in the dimensionless time tau = n t with step 1e-4. Truncation:
    # h^2 |f'''| / 6 relative to f'; near periapsis at e = 0.8 the time scale is about
    # (1-e)^1.5 / (1+e)^0.5 ~ 1/15 of 1/n, so f''' / f' ~ 15^2 and the error ~4e-7.
    # Roundoff: EPS |f| / h ~ 2e-16 * 25 / 1e-4 = 5e-11. The step keeps both below 1e-5.
    h = 1e-4 / n
    fd = (f_of_t(orbit, t + h) - f_of_t(orbit, t - h)) / (2 * h)
    np.testing.assert_allclose(g, fd, rtol=1e-5)


@pytest.mark.parametrize("e", [0.1, 0.5, 0.8])
def test_grad_true_anomaly_wrt_eccentricity(e):
    orbit = orbit_(a=2.0e7, e=e, f0=0.7)
    T = float(orbit.period)
    t = np.linspace(-1.2 * T, 3.4 * T, 23)
    g = dfde(orbit, t).e
    # Central differences in e with h = 1e-6: truncation h^2 |d3f/de3| / 6 with d3f/de3 up
    # to O(1e3) at e = 0.8 -> ~2e-10; roundoff EPS |f| / h ~ 2e-16 * 25 / 1e-6 = 5e-9 rad.
    # h ~ (3 EPS |f| / |f'''|)^(1/3) ~ 1e-6 balances the two; their sum ~1e-8 is covered by
    # atol 5e-8 (|df/de| is O(1..30)).
    h = 1e-6
    fd = (f_of_t(with_(orbit, e=e + h), t) - f_of_t(with_(orbit, e=e - h), t)) / (2 * h)
    np.testing.assert_allclose(g, fd, rtol=1e-6, atol=5e-8)
    # Exact cross-check: at fixed t, f(e) solves t(f, e) = t, so df/de = -(dt/de)/(dt/df),
    # both from plain autodiff (no root solve). Rounding ~1e-13 relative, amplified by
    # 1/(k2 dt/df) = rho^2 <= 3.3: 1e-10 relative is loose.
    f = f_of_t(orbit, t)
    want = -dtde(orbit, f).e / dtdf(orbit, f)
    np.testing.assert_allclose(g, want, rtol=1e-10, atol=1e-12)


# --------------------------------------------------------------------------------------------
# elements_to_state follows two-body dynamics
# --------------------------------------------------------------------------------------------


def _two_body(t, y, mu):
    r = y[:3]
    return np.concatenate([y[3:], -mu * r / np.linalg.norm(r) ** 3])


@pytest.mark.parametrize("orbit", GENERIC, ids=lambda o: f"e={float(o.e)}")
def test_elements_to_state_two_body(orbit):
    T = float(orbit.period)
    r0, v0 = to_state(orbit)
    rs, vs = np.linalg.norm(r0), np.linalg.norm(v0)
    times = np.array([0.37, 1.0, 1.81, 2.5]) * T
    # rtol 1e-13 (DOP853's local tolerance), atol 1e-15 of the state's scale: the global
    # error after 2.5 periods stays ~1e-11 relative (accumulated 1e-13 local errors).
    sol = solve_ivp(_two_body, (0.0, times[-1]), np.concatenate([r0, v0]), method="DOP853",
                    rtol=1e-13, atol=np.r_[np.full(3, 1e-15 * rs), np.full(3, 1e-15 * vs)],
                    t_eval=times, args=(float(orbit.mu),))
    assert sol.success
    f = f_of_t(orbit, times)
    for k in range(times.size):
        r, v = to_state(orbit, f[k])
        yk = sol.y[:, k]
        # Required 1e-10 relative: integrator error ~1e-11 (above) plus the Kepler solve
        # (~1e-13 rad) times |r|.
        assert np.linalg.norm(yk[:3] - r) <= 1e-10 * np.linalg.norm(r), k
        assert np.linalg.norm(yk[3:] - v) <= 1e-10 * np.linalg.norm(v), k


# --------------------------------------------------------------------------------------------
# frames
# --------------------------------------------------------------------------------------------

CHIEF = orbit_(a=2.0e7, e=0.3, i=1.1, raan=0.3, argp=2.0, f0=0.4)
DEPUTY = with_(CHIEF, a=2.0e7 + 1500.0, e=0.3 + 1e-4, i=1.1 + 2e-5, raan=0.3 - 3e-5,
               argp=2.0 + 1e-5, f0=0.4 - 2e-5)


def _lvlh_at_time(chief, deputy, t):
    rc, vc = elements_to_state(chief, true_anomaly_from_time(chief, t))
    rd, vd = elements_to_state(deputy, true_anomaly_from_time(deputy, t))
    return inertial_to_lvlh(rc, vc, rd, vd)


_lvlh_at_times = jax.jit(jax.vmap(_lvlh_at_time, in_axes=(None, None, 0)))


def lvlh_at_times(t):
    """The deputy's LVLH state at times t (padded to NPAD: one compilation)."""
    t = np.asarray(t, dtype=np.float64)
    return np.asarray(_lvlh_at_times(CHIEF, DEPUTY, np.r_[t, np.zeros(NPAD - t.size)]))[: t.size]


@pytest.mark.parametrize("orbit", GENERIC, ids=lambda o: f"e={float(o.e)}")
def test_lvlh_basis(orbit):
    for f in (0.0, 1.3, 3.0, 5.5):
        r, v = to_state(orbit, f)
        C = np.asarray(lvlh_basis(r, v))
        # Unit vectors from normalised cross products: a few EPS.
        np.testing.assert_allclose(C @ C.T, np.eye(3), rtol=0, atol=10 * EPS)
        assert abs(np.linalg.det(C) - 1.0) <= 10 * EPS  # right-handed
        np.testing.assert_allclose(C[0], r / np.linalg.norm(r), rtol=0, atol=10 * EPS)
        h = np.cross(r, v)
        np.testing.assert_allclose(C[2], h / np.linalg.norm(h), rtol=0, atol=10 * EPS)
        # y is along-track: v has the transverse speed |h|/|r| > 0 along y and the radial
        # speed r.v/|r| along x, nothing along z (a few EPS of |v|).
        vl = C @ v
        rn = np.linalg.norm(r)
        np.testing.assert_allclose(vl[1], np.linalg.norm(h) / rn, rtol=10 * EPS)
        np.testing.assert_allclose(vl[0], np.dot(r, v) / rn, rtol=0,
                                   atol=10 * EPS * np.linalg.norm(v))
        assert abs(vl[2]) <= 10 * EPS * np.linalg.norm(v)


def test_inertial_lvlh_round_trip():
    rng = np.random.default_rng(7)
    for orbit in GENERIC:
        for f in (0.2, 2.9, 4.4):
            rc, vc = to_state(orbit, f)
            dr = rng.normal(size=3) * 1e3
            dv = rng.normal(size=3) * 1.0
            x = np.asarray(relative_inertial_to_lvlh(rc, vc, dr, dv))
            # inertial_to_lvlh on absolute states is the same map; forming rc + dr rounds dr
            # to EPS |rc| (~5e-9 m at |rc| ~ 4e7 m): 100 EPS of |rc|, |vc| bounds it.
            x2 = np.asarray(inertial_to_lvlh(rc, vc, rc + dr, vc + dv))
            np.testing.assert_allclose(x2[:3], x[:3], rtol=0,
                                       atol=100 * EPS * np.linalg.norm(rc))
            np.testing.assert_allclose(x2[3:], x[3:], rtol=0,
                                       atol=100 * EPS * np.linalg.norm(vc))
            # A rotation keeps |dr| (a few EPS).
            assert abs(np.linalg.norm(x[:3]) - np.linalg.norm(dr)) <= (
                10 * EPS * np.linalg.norm(dr))
            # Round trip to inertial: a few EPS of |dr|; the velocity adds and removes w x dr
            # (|w dr| <~ 1 m/s here, like |dv|): 100 EPS of |dv|.
            dr2, dv2 = (np.asarray(y) for y in lvlh_to_relative_inertial(rc, vc, x))
            np.testing.assert_allclose(dr2, dr, rtol=0, atol=10 * EPS * np.linalg.norm(dr))
            np.testing.assert_allclose(dv2, dv, rtol=0, atol=100 * EPS * np.linalg.norm(dv))
            # The velocity is the rotating-frame one: C (dv - w x dr), w = h / |r|^2.
            w = np.cross(rc, vc) / np.dot(rc, rc)
            C = np.asarray(lvlh_basis(rc, vc))
            np.testing.assert_allclose(x[3:], C @ (dv - np.cross(w, dr)), rtol=0,
                                       atol=10 * EPS * np.linalg.norm(dv))


def test_lvlh_velocity_is_rotating_frame_derivative():
    T = float(CHIEF.period)
    t = np.linspace(0.05, 2.3, 9) * T
    h = 20.0
    # One batched call: t and t + k h, k = -2, -1, 1, 2.
    x_all = lvlh_at_times(np.concatenate([t + k * h for k in (0, -2, -1, 1, 2)]))
    x = x_all[: t.size]
    pos = [x_all[j * t.size: (j + 1) * t.size, :3] for j in range(1, 5)]
    # 4th-order central difference of the LVLH position in time, h = 20 s. Truncation
    # h^4 |x^(5)| / 30 with |x^(5)| ~ (k2 rho^2)^5 |x| ~ (4e-4)^5 * 2e3 m ~ 2e-14 m/s^5:
    # ~1e-10 m/s. Roundoff: positions are differences of |r| ~ 2.6e7 m vectors (EPS |r| ~
    # 6e-9 m), times 18 / (12 h): ~4e-10 m/s. Both well below 1e-8 of the ~1 m/s velocity.
    fd = (pos[0] - 8 * pos[1] + 8 * pos[2] - pos[3]) / (12 * h)
    vel = x[:, 3:]
    scale = np.max(np.abs(vel))
    assert scale > 0.1  # the deputy does move in the LVLH frame
    np.testing.assert_allclose(vel, fd, rtol=0, atol=1e-8 * scale)
    # The transport term C (w x dr) separating this from the inertial velocity difference
    # rotated into LVLH is > 1e6 times the tolerance, so a non-rotating velocity would fail.
    rc, vc = to_state(CHIEF, f_of_t(CHIEF, t[:1])[0])
    C = np.asarray(lvlh_basis(rc, vc))
    w = np.cross(rc, vc) / np.dot(rc, rc)
    assert np.linalg.norm(C @ np.cross(w, C.T @ x[0, :3])) > 1e-2 * scale


@pytest.mark.parametrize("e", [0.0, 0.3, 0.8])
def test_lvlh_th_round_trip(e):
    k2 = float(orbit_(a=2.0e7, e=e).k2)
    x = np.array([120.0, -340.0, 55.0, 0.031, -0.12, 0.07])
    for f in (0.0, 1.0, 2.5, 4.0, 9.0, -3.0):
        th = np.asarray(lvlh_to_th(x, f, e, k2))
        back = np.asarray(th_to_lvlh(th, f, e, k2))
        rho = 1 + e * np.cos(f)
        # The documented position map x~ = rho x (one rounding).
        np.testing.assert_allclose(th[:3], rho * x[:3], rtol=10 * EPS)
        # Products and quotients by rho in [0.2, 1.8]: a few EPS of the position scale.
        np.testing.assert_allclose(back[:3], x[:3], rtol=0,
                                   atol=10 * EPS * np.max(np.abs(x[:3])))
        # The velocity adds and removes k2 e sin f x~ (~1.6e-4 /s * 300 m ~ 0.05 m/s, like
        # v): a few EPS of both terms.
        vscale = np.max(np.abs(x[3:])) + k2 * np.max(np.abs(th[:3]))
        np.testing.assert_allclose(back[3:], x[3:], rtol=0, atol=10 * EPS * vscale)
        th2 = np.asarray(lvlh_to_th(back, f, e, k2))
        np.testing.assert_allclose(th2, th, rtol=0, atol=10 * EPS * np.max(np.abs(th)))


def test_th_velocity_is_true_anomaly_derivative():
    """x~' from lvlh_to_th is d(rho x)/df along a real deputy trajectory."""
    e, k2 = float(CHIEF.e), float(CHIEF.k2)
    f = np.linspace(0.5, 0.5 + 4 * np.pi, 11)
    h = 5e-3
    ff = np.concatenate([f + k * h for k in (0, -2, -1, 1, 2)])
    x_all = lvlh_at_times(t_of_f(CHIEF, ff))
    th_all = np.asarray(jax.vmap(lvlh_to_th, in_axes=(0, 0, None, None))(x_all, ff, e, k2))
    th = th_all[: f.size]
    pos = [th_all[j * f.size: (j + 1) * f.size, :3] for j in range(1, 5)]
    # 4th-order central difference in f, h = 5e-3 rad. Truncation h^4 |x~^(5)| / 30 ~
    # 2e-11 * O(10) |x~| ~ 1e-7 m/rad; roundoff ~6e-9 m * 18 / (12 h) ~ 2e-6 m/rad. Both
    # below 1e-8 of |x~'| ~ 1e3 m/rad.
    fd = (pos[0] - 8 * pos[1] + 8 * pos[2] - pos[3]) / (12 * h)
    scale = np.max(np.abs(th[:, 3:]))
    np.testing.assert_allclose(th[:, 3:], fd, rtol=0, atol=1e-8 * scale)
