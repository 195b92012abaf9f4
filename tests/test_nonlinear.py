"""Tests of the nonlinear dynamics: two-body + J2 gravity, the LVLH frame's angular velocity
for a perturbed chief, and exact relative motion in LVLH.

Independent integrator: scipy.integrate.solve_ivp, DOP853 at rtol 1e-12 (1e-13 for the short
finite-difference arcs) with atol = rtol times each component's scale, on jitted right-hand
sides. Its global error over a few revolutions is ~1e-11 relative (accumulated local errors),
which sets the tolerances below.
"""

import jax

jax.config.update("jax_enable_x64", True)

from decimal import Decimal, getcontext  # noqa: E402

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402

from jaxlpm.constants import J2_EARTH, MU_EARTH, R_EARTH  # noqa: E402
from jaxlpm.dynamics import (  # noqa: E402
    chief_polar_rates, elliptic_lvlh_matrix, elliptic_lvlh_rhs, gravity_acceleration,
    gravity_acceleration_difference, inertial_rhs, j2_acceleration, j2_potential,
    relative_inertial_rhs, relative_lvlh_rhs, two_body_acceleration)
from jaxlpm.orbits import KeplerOrbit, elements_to_state, lvlh_basis  # noqa: E402
from jaxlpm.orbits.frames import (lvlh_angular_velocity, lvlh_to_relative_inertial,  # noqa: E402
                                 relative_inertial_to_lvlh)

F64 = np.float64
RTOL = 1e-12
# Chief: mei2010's a = 9500 km, e = 0.3 (perigee 6650 km, where J2 is strongest), i = 30 deg.
CHIEF = KeplerOrbit(a=F64(9500e3), e=F64(0.3), i=np.deg2rad(30.0), raan=np.deg2rad(30.0),
                    argp=np.deg2rad(10.0), f0=F64(0.4), mu=F64(MU_EARTH))
PERIOD = float(CHIEF.period)
X0_LVLH = np.array([4000.0, 8000.0, -4000.0, 1.0, -8.0, 2.0])  # ~10 km, ~8 m/s: generic


def chief_state(f=None):
    r, v = elements_to_state(CHIEF, f)
    return np.concatenate([r, v])


@pytest.fixture(scope="module")
def rhs():
    """Jitted right-hand sides, compiled once per module (mu, j2, r_eq traced, not static)."""
    inertial = jax.jit(lambda y, j2: inertial_rhs(y, jnp.zeros(3), MU_EARTH, j2, R_EARTH))

    def chief_and_lvlh(y, j2):
        """The chief inertially beside the deputy's LVLH state (12,)."""
        chief, x = y[:6], y[6:]
        return jnp.concatenate([inertial_rhs(chief, jnp.zeros(3), MU_EARTH, j2, R_EARTH),
                                relative_lvlh_rhs(chief, x, jnp.zeros(3), MU_EARTH, j2, R_EARTH)])

    return {"inertial": inertial, "lvlh": jax.jit(chief_and_lvlh)}


def integrate(fun, y0, t_eval, scale, rtol=RTOL, j2=0.0):
    """DOP853 from 0 to t_eval[-1] (states at t_eval; the last one is a step end, not dense
    output); atol = rtol * scale per component."""
    sol = solve_ivp(lambda t, y: np.asarray(fun(y, j2)), (0.0, t_eval[-1]), y0,
                    method="DOP853", rtol=rtol, atol=rtol * scale, t_eval=t_eval)
    assert sol.success
    return sol.y.T


def inertial_scale(y0):
    return np.r_[np.full(3, np.linalg.norm(y0[:3])), np.full(3, np.linalg.norm(y0[3:6]))]


def energy(y, j2):
    """Specific energy v^2/2 - mu/r - U_J2 (a = +grad(mu/r + U_J2), so -U is potential energy)."""
    r, v = y[:3], y[3:]
    return (0.5 * np.dot(v, v) - MU_EARTH / np.linalg.norm(r)
            - float(j2_potential(r, MU_EARTH, j2, R_EARTH)))


# --------------------------------------------------------------------------------------------
# gravity
# --------------------------------------------------------------------------------------------


def test_two_body_invariants(rhs):
    """Energy and angular momentum are constant along an e = 0.3 orbit over 3 revolutions."""
    y0 = chief_state()
    ys = integrate(rhs["inertial"], y0, np.linspace(0.0, 3.0, 61) * PERIOD, inertial_scale(y0))
    E = np.array([energy(y, 0.0) for y in ys])
    h = np.cross(ys[:, :3], ys[:, 3:])
    # Global error ~1e-11 relative after 3 revolutions (rtol 1e-12 per step, ~1e3 steps,
    # partly cancelling; measured 2e-11 in E, 1e-11 in h): 2e-10 leaves a 10x margin; a
    # wrong sign or factor in the acceleration changes E and h at O(1).
    assert np.max(np.abs(E / E[0] - 1.0)) < 2e-10
    assert np.max(np.linalg.norm(h - h[0], axis=1)) < 2e-10 * np.linalg.norm(h[0])
    # The orbit really is the e = 0.3 ellipse: the radius spans a (1 -+ e).
    rn = np.linalg.norm(ys[:, :3], axis=1)
    assert rn.min() < 0.72 * float(CHIEF.a) and rn.max() > 1.28 * float(CHIEF.a)


def test_j2_acceleration_is_gradient_of_potential():
    rng = np.random.default_rng(3)
    grad = jax.jit(jax.grad(j2_potential))
    # Random directions (all latitudes) plus the poles and the equator, 6600 km to 42000 km.
    dirs = np.r_[rng.normal(size=(20, 3)), [[0, 0, 1.0], [0, 0, -1.0], [1.0, 0, 0]]]
    for d, rn in zip(dirs, np.geomspace(6.6e6, 4.2e7, len(dirs))):
        r = d / np.linalg.norm(d) * rn
        a = np.asarray(j2_acceleration(r, MU_EARTH, J2_EARTH, R_EARTH))
        g = np.asarray(grad(r, MU_EARTH, J2_EARTH, R_EARTH))
        # Same quantity by two roundings of ~10 flops each: 1e-14 of |a_J2|.
        np.testing.assert_allclose(a, g, rtol=0, atol=1e-14 * np.linalg.norm(g))
        # j2 = 0 is exactly two-body; J2 is ~1e-3 of it near the Earth (not zero).
        np.testing.assert_array_equal(gravity_acceleration(r, MU_EARTH, 0.0, R_EARTH),
                                      two_body_acceleration(r, MU_EARTH))
    a_eq = j2_acceleration(np.array([R_EARTH, 0.0, 0.0]), MU_EARTH, J2_EARTH, R_EARTH)
    # At the equator J2 pulls inward by (3/2) J2 mu / R^2 (the equatorial bulge).
    np.testing.assert_allclose(a_eq, [-1.5 * J2_EARTH * MU_EARTH / R_EARTH**2, 0.0, 0.0],
                               rtol=1e-14)


def test_j2_invariants(rhs):
    """Under two-body + J2: v^2/2 - mu/r - U_J2 and h_z are conserved (axisymmetric field);
    the Keplerian energy and h_x, h_y are not (so the check sees J2)."""
    y0 = chief_state()
    ys = integrate(rhs["inertial"], y0, np.linspace(0.0, 3.0, 61) * PERIOD, inertial_scale(y0),
                   j2=J2_EARTH)
    E = np.array([energy(y, J2_EARTH) for y in ys])
    h = np.cross(ys[:, :3], ys[:, 3:])
    hn = np.linalg.norm(h[0])
    # As in the two-body test: integrator error ~1e-11 relative (measured 2.4e-11), 2e-10.
    assert np.max(np.abs(E / E[0] - 1.0)) < 2e-10
    assert np.max(np.abs(h[:, 2] - h[0, 2])) < 2e-10 * hn
    kepler = np.array([energy(y, 0.0) for y in ys])
    opposite = kepler - (E - kepler)  # the potential's sign flipped
    # Each of these varies by ~1e-3 (measured 9e-4, 2e-3, 7e-3), > 1e6 times the bound.
    assert np.max(np.abs(kepler / kepler[0] - 1.0)) > 1e-4
    assert np.max(np.abs(opposite / opposite[0] - 1.0)) > 1e-4
    assert np.max(np.linalg.norm(h[:, :2] - h[0, :2], axis=1)) > 1e-4 * hn  # node precesses


def _exact_gravity_difference(r, dr, j2):
    """a(r + dr) - a(r) in 60-digit decimal arithmetic from the float64 inputs (exact sum)."""
    getcontext().prec = 60
    mu, k = Decimal(MU_EARTH), Decimal(-1.5) * Decimal(MU_EARTH) * Decimal(j2) * Decimal(R_EARTH)**2

    def acc(p):
        rn = sum(c * c for c in p).sqrt()
        s2 = p[2] * p[2] / (rn * rn)
        q = [p[0] * (1 - 5 * s2), p[1] * (1 - 5 * s2), p[2] * (3 - 5 * s2)]
        return [-mu * c / rn**3 + k * qc / rn**5 for c, qc in zip(p, q)]

    r0 = [Decimal(float(c)) for c in r]
    r1 = [c + Decimal(float(d)) for c, d in zip(r0, dr)]
    return np.array([float(b - a) for a, b in zip(acc(r0), acc(r1))])


@pytest.mark.parametrize("sep", [1.0, 100.0, 1e5])
def test_gravity_difference_keeps_precision(sep):
    """gravity_acceleration_difference is accurate to rounding relative to the difference
    itself, where naive subtraction loses EPS |r| / |dr| (2e-9 at 1 m)."""
    rng = np.random.default_rng(int(sep))
    diff = jax.jit(gravity_acceleration_difference)
    for _ in range(3):
        r = rng.normal(size=3)
        r *= rng.uniform(6.6e6, 4.2e7) / np.linalg.norm(r)
        dr = rng.normal(size=3)
        dr *= sep / np.linalg.norm(dr)
        for j2 in (0.0, J2_EARTH):
            want = _exact_gravity_difference(r, dr, j2)
            got = np.asarray(diff(r, dr, MU_EARTH, j2, R_EARTH))
            # ~30 flops, each a relative rounding: 1e-14 of |Delta a|.
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-14 * np.linalg.norm(want))


@pytest.mark.parametrize("j2", [None, 0.0, J2_EARTH])
def test_gravity_difference_derivatives_are_those_of_the_field(j2):
    """The derivatives of gravity_acceleration_difference (its custom JVP: the field's own
    Jacobian at r + dr and r) equal autodiff of the plain difference a(r + dr) - a(r): first
    derivatives in r, dr, mu, j2, r_eq and the second in dr (Newton-KKT's Hessian). Both
    are the same formulas in another order: agreement to ~1e-12 of each derivative's size
    (the r derivative J(r + dr) - J(r) cancels in both alike, to eps |r| / |dr| ~ 2e-13 at
    10 km). j2 = None: two-body alone, equal to j2 = 0."""
    rng = np.random.default_rng(7)
    r = rng.normal(size=3)
    r *= 7.2e6 / np.linalg.norm(r)
    dr = rng.normal(size=3) * 1e4
    jj = J2_EARTH if j2 is None else j2

    def plain(r, dr, mu, j2v, r_eq):
        a = lambda x: gravity_acceleration(x, mu, None if j2 is None else j2v, r_eq)  # noqa
        return a(r + dr) - a(r)

    def ours(r, dr, mu, j2v, r_eq):
        return gravity_acceleration_difference(r, dr, mu, None if j2 is None else j2v, r_eq)

    args = (r, dr, MU_EARTH, jj, R_EARTH)
    for k in range(5):
        want = np.asarray(jax.jacfwd(plain, argnums=k)(*args))
        got = np.asarray(jax.jacfwd(ours, argnums=k)(*args))
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * np.max(np.abs(want)) + 1e-300)
        got_rev = np.asarray(jax.jacrev(ours, argnums=k)(*args))
        np.testing.assert_allclose(got_rev, want, rtol=0, atol=1e-12 * np.max(np.abs(want)) + 1e-300)
    want = np.asarray(jax.hessian(plain, argnums=1)(*args))
    got = np.asarray(jax.hessian(ours, argnums=1)(*args))
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * np.max(np.abs(want)))
    if j2 is None:
        np.testing.assert_array_equal(np.asarray(ours(*args)), np.asarray(
            gravity_acceleration_difference(r, dr, MU_EARTH, 0.0, R_EARTH)))


# --------------------------------------------------------------------------------------------
# LVLH frame of a J2-perturbed chief
# --------------------------------------------------------------------------------------------


def test_lvlh_angular_velocity_finite_difference(rhs):
    """w of `lvlh_angular_velocity` (with the chief's J2 acceleration) is the angular velocity
    of lvlh_basis along the J2 flow: C_dot C^T = [w]x in LVLH axes (rows e_i, e_i_dot = w x e_i,
    so (C_dot C^T)_ij = w . (e_i x e_j))."""
    y0 = chief_state()
    pts = integrate(rhs["inertial"], y0, np.array([0.0, 0.05, 0.31, 0.5, 0.77]) * PERIOD,
                    inertial_scale(y0), j2=J2_EARTH)
    h = 2.0  # s
    for y in pts:
        # States at t +- h, +- 2h, each the end of its own integration (rtol 1e-13).
        C = {}
        for k in (-2, -1, 1, 2):
            yk = integrate(lambda s, j2: -rhs["inertial"](s, j2) if k < 0 else
                           rhs["inertial"](s, j2), y, np.array([abs(k) * h]),
                           inertial_scale(y), rtol=1e-13, j2=J2_EARTH)[-1]
            C[k] = np.asarray(lvlh_basis(yk[:3], yk[3:]))
        Cd = (C[-2] - 8 * C[-1] + 8 * C[1] - C[2]) / (12 * h)
        W = Cd @ np.asarray(lvlh_basis(y[:3], y[3:])).T
        w_fd = np.array([W[1, 2], W[2, 0], W[0, 1]])
        r, v = y[:3], y[3:]
        a = gravity_acceleration(r, MU_EARTH, J2_EARTH, R_EARTH)
        Cy = np.asarray(lvlh_basis(r, v))
        w = Cy @ np.asarray(lvlh_angular_velocity(r, v, a))
        # Truncation h^4 |C^(5)| / 30, |C^(5)| ~ f_dot^5 (f_dot <~ 1.3e-3 /s): ~2e-15 rad/s
        # (measured 1e-14; 4e-13 at h = 5 s, the h^4 law); the states' error (1e-13
        # relative) times 18 / (12 h): ~1e-14 rad/s. Bound 1e-13 rad/s: 1e-10 of f_dot,
        # 1e-6 of the J2 term w_x (6e-8..9e-7 rad/s along this orbit).
        np.testing.assert_allclose(w, w_fd, rtol=0, atol=1e-13)
        assert abs(w_fd[0]) > 1e5 * 1e-13  # the J2 term is resolved ...
        w_kepler = Cy @ np.asarray(lvlh_angular_velocity(r, v))
        assert abs(w_kepler[0] - w_fd[0]) > 1e5 * 1e-13  # ... and the Keplerian w misses it


# --------------------------------------------------------------------------------------------
# relative motion in LVLH
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("j2", [0.0, J2_EARTH], ids=["two-body", "J2"])
def test_relative_lvlh_matches_two_inertial_trajectories(rhs, j2):
    """Integrating relative_lvlh_rhs over ~1 revolution gives the LVLH map (with the chief's
    acceleration) of the chief's and the deputy's separately integrated inertial orbits."""
    t = np.array([1.05 * PERIOD])
    y0 = chief_state()
    rc, vc = y0[:3], y0[3:]
    dr, dv = lvlh_to_relative_inertial(rc, vc, X0_LVLH,
                                       gravity_acceleration(rc, MU_EARTH, j2, R_EARTH))
    yd0 = np.concatenate([rc + dr, vc + dv])
    chief = integrate(rhs["inertial"], y0, t, inertial_scale(y0), j2=j2)[-1]
    deputy = integrate(rhs["inertial"], yd0, t, inertial_scale(yd0), j2=j2)[-1]
    scale = np.r_[inertial_scale(y0), np.full(3, 1e4), np.full(3, 10.0)]
    x = integrate(rhs["lvlh"], np.concatenate([y0, X0_LVLH]), t, scale, j2=j2)[-1, 6:]
    rc, vc = chief[:3], chief[3:]
    ac = gravity_acceleration(rc, MU_EARTH, j2, R_EARTH)
    want = np.asarray(relative_inertial_to_lvlh(rc, vc, deputy[:3] - rc, deputy[3:] - vc, ac))
    assert np.linalg.norm(want[:3] - X0_LVLH[:3]) > 1e3  # the deputy has moved
    # Each inertial orbit carries ~1e-11 relative error (~1e-4 m at 1e7 m), and so does the
    # LVLH integration (measured 3e-11..6e-11 of the relative state): bound 1e-9.
    np.testing.assert_allclose(x[:3], want[:3], rtol=0, atol=1e-9 * np.linalg.norm(want[:3]))
    np.testing.assert_allclose(x[3:], want[3:], rtol=0, atol=1e-9 * np.linalg.norm(want[3:]))
    if j2:  # the J2 frame rotation matters at this level: the Keplerian w misses by ~1e-3
        kepler = np.asarray(relative_inertial_to_lvlh(rc, vc, deputy[:3] - rc, deputy[3:] - vc))
        assert np.max(np.abs(kepler[3:] - want[3:])) > 1e-5 * np.linalg.norm(want[3:])


def test_relative_lvlh_small_separation_is_linear_model():
    """For rho -> 0 (j2 = 0) relative_lvlh_rhs tends to the linear elliptic model with a
    relative error O(rho / r) that scales linearly with rho, and its Jacobian at rho = 0 is
    elliptic_lvlh_matrix (checks the derivative too)."""
    e, k2, p = F64(CHIEF.e), F64(CHIEF.k2), F64(CHIEF.p)
    rate = jax.jit(lambda c, x: relative_lvlh_rhs(c, x, jnp.zeros(3), MU_EARTH, 0.0, R_EARTH))
    jac = jax.jit(jax.jacfwd(relative_lvlh_rhs, argnums=1))
    direction = X0_LVLH / np.linalg.norm(X0_LVLH[:3])
    for f in (0.0, 1.0, 2.5, 4.0):
        chief = chief_state(F64(f))
        rho, w, w_dot = chief_polar_rates(f, e, k2)
        r = p / float(rho)
        A = np.asarray(elliptic_lvlh_matrix(r, w, w_dot, MU_EARTH))
        J = np.asarray(jac(chief, np.zeros(6), np.zeros(3), MU_EARTH, 0.0, R_EARTH))
        # Both exact up to rounding; scaled by w (S A S^-1 / w, S = diag(1, 1/w)) the entries
        # are O(1): measured 2e-15, bound 1e-13.
        S = np.diag(np.r_[np.ones(3), np.full(3, 1.0 / float(w))])
        np.testing.assert_allclose(S @ J @ np.linalg.inv(S) / float(w),
                                   S @ A @ np.linalg.inv(S) / float(w), rtol=0, atol=1e-13)
        errs = []
        for sep in (1.0, 100.0):
            x = sep * direction
            nl = np.asarray(rate(chief, x))
            lin = np.asarray(elliptic_lvlh_rhs(f, x, np.zeros(3), e, k2, p, MU_EARTH))
            np.testing.assert_allclose(nl[:3], x[3:], rtol=1e-14)
            errs.append(np.linalg.norm(nl[3:] - lin[3:]) / np.linalg.norm(lin[3:]))
        # The quadratic gravity term is ~(3/2)(rho/r) mu rho / r^3; against |A x| (partly
        # cancelling terms ~w^2 rho) it measured 0.7..2.8 rho/r: O(rho / r), bound 10 rho/r.
        assert errs[0] < 10.0 / r
        # Linear in rho: the cubic term shifts the ratio by ~100 / r ~ 1e-5 relative
        # (measured 5e-6..9e-6); rounding (1e-15 against 1e-7) is negligible.
        assert errs[1] / errs[0] == pytest.approx(100.0, rel=1e-4)


def test_jit_vmap_matches_loop():
    rng = np.random.default_rng(11)
    n = 8
    chiefs = np.stack([chief_state(F64(f)) for f in rng.uniform(0.0, 2 * np.pi, n)])
    xs = rng.normal(size=(n, 6)) * np.r_[np.full(3, 1e4), np.full(3, 10.0)]
    us = rng.normal(size=(n, 3)) * 1e-3
    j2s = rng.uniform(0.0, 2.0, n) * J2_EARTH  # j2 is an array leaf, batched too
    batched = jax.jit(jax.vmap(relative_lvlh_rhs, in_axes=(0, 0, 0, None, 0, None)))
    got = np.asarray(batched(chiefs, xs, us, MU_EARTH, j2s, R_EARTH))
    s = np.concatenate([chiefs, xs], axis=1)  # as [r_c, v_c, dr, dv] for the inertial form
    got_in = np.asarray(jax.jit(jax.vmap(relative_inertial_rhs, in_axes=(0, 0, None, 0, None)))(
        s, us, MU_EARTH, j2s, R_EARTH))
    one, one_in = jax.jit(relative_lvlh_rhs), jax.jit(relative_inertial_rhs)
    for k in range(n):
        want = one(chiefs[k], xs[k], us[k], MU_EARTH, j2s[k], R_EARTH)
        np.testing.assert_allclose(got[k], want, rtol=1e-13, atol=1e-13 * np.max(np.abs(want)))
        want_in = one_in(s[k], us[k], MU_EARTH, j2s[k], R_EARTH)
        np.testing.assert_allclose(got_in[k], want_in, rtol=1e-13, atol=0)
