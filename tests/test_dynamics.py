"""Tests of jaxlpm.dynamics: HCW, the elliptic linearised LVLH model in time, the
Tschauner-Hempel (TH) model in true anomaly and the Yamanaka-Ankersen (YA) STM.

Requirement: each linear model agrees with numerical integration to a relative error
<= 1e-10 over several revolutions, e up to 0.8. The independent integrator is
scipy.integrate.solve_ivp (DOP853, rtol 1e-13, atol ~1e-15 of the state's scale); its global
error over 3 revolutions is ~1e-13..1e-11 relative (measured: 2e-11 at e = 0.8, where the
periapsis passes are 15 times faster than the mean motion), which is the margin the 1e-10
bounds leave. Relative error = max |err| / max |x| over the samples, per block (position,
velocity) where the blocks have different units.
"""

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp
import numpy as np
import pytest
from jax.scipy.linalg import expm
from scipy.integrate import solve_ivp

from jaxlpm.constants import MU_EARTH
from jaxlpm.dynamics import (
    chief_polar_rates,
    elliptic_lvlh_matrix,
    elliptic_lvlh_rhs,
    hcw_drift,
    hcw_matrix,
    hcw_rhs,
    tschauner_hempel_drift,
    tschauner_hempel_input_gain,
    tschauner_hempel_matrix,
    tschauner_hempel_rhs,
    yamanaka_ankersen_inplane,
    yamanaka_ankersen_outofplane,
    yamanaka_ankersen_stm,
)
from jaxlpm.orbits import (
    KeplerOrbit,
    elements_to_state,
    inertial_to_lvlh,
    lvlh_to_relative_inertial,
    lvlh_to_th,
    th_to_lvlh,
    time_from_true_anomaly,
    true_anomaly_from_time,
)

EPS = np.finfo(np.float64).eps
TWO_PI = 2.0 * np.pi
RTOL = 1e-13  # DOP853 local tolerance for every integration below
NSAMP = 61    # samples per trajectory (fixed: one compilation of each batched function)
F64 = np.float64
A_CHIEF = 4.2e7  # m; perigee 8400 km at e = 0.8
X0_LVLH = np.array([300.0, -500.0, 200.0, 0.01, -0.02, 0.015])  # m, m/s: drifting, generic


def orbit_(e, f0=0.0, a=A_CHIEF):
    """Chief orbit with float64 leaves (one abstract signature for every jitted function)."""
    return KeplerOrbit(a=F64(a), e=F64(e), i=F64(0.5), raan=F64(1.0), argp=F64(2.0), f0=F64(f0),
                       mu=F64(MU_EARTH))


def rel_err(got, want):
    """max |got - want| / max |want|."""
    return np.max(np.abs(np.asarray(got) - np.asarray(want))) / np.max(np.abs(want))


# ---- compiled once, reused by every case ---------------------------------------------------

_hcw_rhs = jax.jit(lambda t, x, n: hcw_rhs(t, x, jnp.zeros(3), n))
_hcw_expm = jax.jit(jax.vmap(lambda t, x0, n: expm(hcw_matrix(n) * t) @ x0, in_axes=(0, None, None)))
_th_rhs = jax.jit(tschauner_hempel_rhs)
_ell_rhs = jax.jit(elliptic_lvlh_rhs)
_stm = jax.jit(yamanaka_ankersen_stm)


def _th_samples(orbit, f, x0_th):
    """YA propagation of x0_th from orbit.f0 to each f, with dt = t(f) - t(f0) continuous."""
    def one(fk):
        dt = time_from_true_anomaly(orbit, fk)
        return yamanaka_ankersen_stm(fk, orbit.f0, dt, orbit.e, orbit.k2) @ x0_th, dt
    return jax.vmap(one)(f)


def _lvlh_samples(orbit, t, x0_lvlh):
    """LVLH state at times t from the YA STM: x = th_to_lvlh(Phi(f(t), f0; t) lvlh_to_th(x0))."""
    e, k2, f0 = orbit.e, orbit.k2, orbit.f0
    x0_th = lvlh_to_th(x0_lvlh, f0, e, k2)

    def one(tk):
        fk = true_anomaly_from_time(orbit, tk)
        return th_to_lvlh(yamanaka_ankersen_stm(fk, f0, tk, e, k2) @ x0_th, fk, e, k2), fk
    return jax.vmap(one)(t)


th_samples = jax.jit(_th_samples)
lvlh_samples = jax.jit(_lvlh_samples)


def th_rhs(f, x, u, e, k2):
    return np.asarray(_th_rhs(F64(f), x, u, F64(e), F64(k2)))


def ell_rhs_aug(orbit, u):
    """d/dt of [x (LVLH, 6), f]: the library's elliptic_lvlh_rhs for x given the integrated f,
    and the test's own f_dot = k^2 (1 + e cos f)^2."""
    e, k2, p, mu = F64(orbit.e), F64(orbit.k2), F64(orbit.p), F64(orbit.mu)

    def rhs(t, y):
        f = F64(y[6])
        return np.append(np.asarray(_ell_rhs(f, y[:6], u, e, k2, p, mu)),
                         k2 * (1.0 + e * np.cos(f)) ** 2)
    return rhs


# --------------------------------------------------------------------------------------------
# HCW
# --------------------------------------------------------------------------------------------


def test_hcw_against_integration():
    n = F64(np.sqrt(MU_EARTH / 7.0e6**3))
    T = TWO_PI / n
    x0 = np.array([120.0, -300.0, 80.0, 0.05, 0.11, -0.07])
    t = np.linspace(0.0, 3 * T, NSAMP)
    # atol 1e-15 of the state's scale per block (positions ~1e3 m, velocities ~1 m/s).
    sol = solve_ivp(lambda tt, x: np.asarray(_hcw_rhs(F64(tt), x, n)), (0.0, 3 * T), x0,
                    method="DOP853", rtol=RTOL, atol=np.r_[np.full(3, 1e-12), np.full(3, 1e-15)],
                    t_eval=t)
    assert sol.success
    want = np.asarray(_hcw_expm(t, x0, n))
    # Required 1e-10: integrator ~1e-12 after 3 periods; expm of ||A t|| ~ 19 loses ~EPS * 19^2.
    assert rel_err(sol.y.T[:, :3], want[:, :3]) <= 1e-10
    assert rel_err(sol.y.T[:, 3:], want[:, 3:]) <= 1e-10
    # The trajectory drifts along-track (not a trivially periodic test case).
    assert abs(want[-1, 1] - x0[1]) > 1e3


def test_hcw_drift_is_the_matrix_product():
    """The written-out drift of the solvers (`hcw_drift`) is hcw_matrix(n) x: the same
    products summed in another order, so equal to a few ulp (rtol 1e-15)."""
    x = np.array([120.0, -300.0, 80.0, 0.05, 0.11, -0.07])
    n = F64(1.3e-3)
    np.testing.assert_allclose(np.asarray(hcw_drift(jnp.asarray(x), n)),
                               np.asarray(hcw_matrix(n)) @ x, rtol=1e-15, atol=0)


def test_hcw_no_drift_condition_gives_periodic_motion():
    """HCW sign check independent of expm: with vy0 = -2 n x0 the motion closes after one
    period; any sign error in the Coriolis or 3 n^2 terms makes it drift."""
    n = F64(np.sqrt(MU_EARTH / 7.0e6**3))
    T = TWO_PI / n
    x0 = np.array([100.0, 50.0, 30.0, 0.02, -2 * n * 100.0, 0.01])
    sol = solve_ivp(lambda tt, x: np.asarray(_hcw_rhs(F64(tt), x, n)), (0.0, T), x0,
                    method="DOP853", rtol=RTOL, atol=np.r_[np.full(3, 1e-12), np.full(3, 1e-15)])
    # Integrator error ~1e-13 relative over one period; 1e-10 of the orbit size.
    assert rel_err(sol.y[:3, -1], x0[:3]) <= 1e-10
    assert rel_err(sol.y[3:, -1], x0[3:]) <= 1e-10
    # ... while half a period later it is far away (the assertion above can fail).
    x_half = np.asarray(_hcw_expm(np.array([T / 2]), x0, n))[0]
    assert rel_err(x_half[:3], x0[:3]) > 0.5


# --------------------------------------------------------------------------------------------
# Tschauner-Hempel in true anomaly vs the YA STM
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("e", [0.0, 0.3, 0.8])
@pytest.mark.parametrize("f0", [0.0, 1.0])
def test_tschauner_hempel_against_stm(e, f0):
    orbit = orbit_(e, f0)
    k2 = F64(orbit.k2)
    x0 = np.asarray(lvlh_to_th(X0_LVLH, f0, e, k2))
    f = np.linspace(f0, f0 + 6 * np.pi, NSAMP)
    u0 = np.zeros(3)

    # Integrate the TH state and, beside it, the time dt/df = 1 / (k2 rho^2) (test's own).
    def rhs(ff, y):
        return np.append(th_rhs(ff, y[:6], u0, e, k2), 1.0 / (k2 * (1 + e * np.cos(ff)) ** 2))

    scale = np.max(np.abs(x0))
    sol = solve_ivp(rhs, (f0, f[-1]), np.append(x0, 0.0), method="DOP853", rtol=RTOL,
                    atol=np.r_[np.full(6, 1e-15 * scale), 1e-15 / k2], t_eval=f)
    assert sol.success
    got, dt = (np.asarray(v) for v in th_samples(orbit, f, x0))
    # Time model: dt from the Kepler closed form vs the integrated time (1e-12 relative:
    # integrator, plus a few EPS on M of size <= 25).
    np.testing.assert_allclose(dt, sol.y[6], rtol=1e-12, atol=1e-12 * dt[-1])
    # Required: relative error of the TH state over 3 revolutions <= 1e-10.
    assert rel_err(got, sol.y[:6].T) <= 1e-10
    # The secular (drift) term matters here: without it the error would be O(1).
    no_drift = np.asarray(_stm(F64(f[-1]), F64(f0), F64(0.0), F64(e), k2)) @ x0
    assert rel_err(no_drift, sol.y[:6, -1]) > 1e-3


# --------------------------------------------------------------------------------------------
# elliptic linearised LVLH model in time vs frames + STM + time model
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("e", [0.3, 0.8])
def test_elliptic_lvlh_time_model_against_stm(e):
    orbit = orbit_(e, f0=1.0)
    T = F64(orbit.period)
    t = np.linspace(0.0, 3 * T, NSAMP)
    y0 = np.append(X0_LVLH, F64(orbit.f0))
    atol = np.r_[np.full(3, 1e-15 * 500), np.full(3, 1e-15 * 0.02), 1e-15]
    sol = solve_ivp(ell_rhs_aug(orbit, np.zeros(3)), (0.0, t[-1]), y0, method="DOP853",
                    rtol=RTOL, atol=atol, t_eval=t)
    assert sol.success
    got, f = (np.asarray(v) for v in lvlh_samples(orbit, t, X0_LVLH))
    # f(t) from the Kepler solve vs the integrated f (rad, |f| <= 20: 1e-12 relative of the
    # integrator plus the solve's ~1e-13).
    np.testing.assert_allclose(f, sol.y[6], rtol=0, atol=1e-11)
    # After exactly 3 periods the chief is back at f0 + 6 pi (continuous, never wrapped).
    assert abs(f[-1] - (F64(orbit.f0) + 6 * np.pi)) <= 1e-11
    # Required: <= 1e-10 relative (positions and velocities separately), at every sample
    # including the end.
    ref = sol.y[:6].T
    assert rel_err(got[:, :3], ref[:, :3]) <= 1e-10
    assert rel_err(got[:, 3:], ref[:, 3:]) <= 1e-10
    assert rel_err(got[-1], ref[-1]) <= 1e-10


# --------------------------------------------------------------------------------------------
# STM properties
# --------------------------------------------------------------------------------------------

STM_E = [0.0, 0.3, 0.8]


def _phi(orbit, f, f_from):
    """Phi(f, f_from) with dt = t(f) - t(f_from) from the continuous time model."""
    dt = time_from_true_anomaly(orbit, f) - time_from_true_anomaly(orbit, f_from)
    return yamanaka_ankersen_stm(f, f_from, dt, orbit.e, orbit.k2)


phi = jax.jit(_phi)
dphi = jax.jit(jax.jacfwd(_phi, argnums=1))  # d/df of Phi(f, f0; t(f) - t(f0))


@pytest.mark.parametrize("e", STM_E)
def test_stm_identity(e):
    orbit = orbit_(e)
    for f0 in (0.0, 1.0, 2.5, -4.0, 9.0):
        P = np.asarray(_stm(F64(f0), F64(f0), F64(0.0), F64(e), F64(orbit.k2)))
        # F(f0) F^-1(f0): products of O(1..10) entries, a few EPS each; 1e-13 absolute.
        np.testing.assert_allclose(P, np.eye(6), rtol=0, atol=1e-13)


@pytest.mark.parametrize("e", STM_E)
def test_stm_composition_and_inverse(e):
    orbit = orbit_(e)
    f0, f1, f2 = F64(0.3), F64(0.3 + 5.0), F64(0.3 + 14.0)  # over 2 revolutions, unwrapped
    P10 = np.asarray(phi(orbit, f1, f0))
    P21 = np.asarray(phi(orbit, f2, f1))
    P20 = np.asarray(phi(orbit, f2, f0))
    # Rounding: each STM carries ~EPS times ||F|| ||F^-1|| (<= 1e3 at e = 0.8 with the
    # secular term k2 dt ~ 25); the product adds ||P21|| ||P10||. 1e-12 of that scale.
    scale = np.linalg.norm(P21) * np.linalg.norm(P10)
    assert np.max(np.abs(P21 @ P10 - P20)) <= 1e-12 * scale
    # Wrapping f or using a wrapped time would break it: Phi(f2 - 2 pi, f1) is different.
    P21w = np.asarray(_stm(f2 - TWO_PI, f1, F64(0.0), F64(e), F64(orbit.k2)))
    assert np.max(np.abs(P21w @ P10 - P20)) > 1e-3 * np.max(np.abs(P20))
    # Inverse: Phi(f0, f2) Phi(f2, f0) = I (backward dt is negative), same scale.
    P02 = np.asarray(phi(orbit, f0, f2))
    assert np.max(np.abs(P02 @ P20 - np.eye(6))) <= 1e-12 * np.linalg.norm(P02) * np.linalg.norm(P20)
    cond = np.linalg.cond(P20)
    np.testing.assert_allclose(P02, np.linalg.inv(P20), rtol=0,
                               atol=1e-13 * cond * np.max(np.abs(P02)))


@pytest.mark.parametrize("e", STM_E)
def test_stm_satisfies_tschauner_hempel_equation(e):
    """d/df Phi(f, f0; t(f) - t0) = A(f) Phi, by forward-mode autodiff through f and t(f)."""
    orbit = orbit_(e)
    for f in (F64(0.7), F64(4.0), F64(11.0)):
        lhs = np.asarray(dphi(orbit, f, F64(0.2)))
        P = np.asarray(phi(orbit, f, F64(0.2)))
        rhs = np.asarray(tschauner_hempel_matrix(f, e)) @ P
        # Both sides exact up to rounding of entries ~||A|| ||P|| (||A|| <= 15 at e = 0.8):
        # 1e-12 of that scale.
        scale = np.linalg.norm(tschauner_hempel_matrix(f, e)) * np.linalg.norm(P)
        assert np.max(np.abs(lhs - rhs)) <= 1e-12 * scale
        # the written-out A(f) x of the solvers (`tschauner_hempel_drift`), column by column
        drift = np.asarray(jax.vmap(lambda x: tschauner_hempel_drift(f, x, e), 1, 1)(P))
        assert np.max(np.abs(drift - rhs)) <= 1e-14 * scale


@pytest.mark.parametrize("e", STM_E)
def test_stm_out_of_plane_block(e):
    """The out-of-plane 2x2 block acts on [z~, z~'] (YA eq. 83), not [z~', z~] as Mei 2010
    prints it: it must reproduce z~ = z0 cos(d) + z0' sin(d), z~' = -z0 sin(d) + z0' cos(d),
    the solution of z~'' = -z~, d = f - f0."""
    orbit = orbit_(e)
    z0, dz0 = 1.3, -0.4
    f0 = F64(0.6)
    for f in (F64(0.6), F64(1.9), F64(4.0), F64(0.6 + 13.0)):
        P = np.asarray(phi(orbit, f, f0))
        d = f - f0
        x0 = np.array([0.0, 0.0, z0, 0.0, 0.0, dz0])
        got = P @ x0
        # Rotation entries from F(f) F^-1(f0): a few EPS.
        want = np.array([z0 * np.cos(d) + dz0 * np.sin(d), -z0 * np.sin(d) + dz0 * np.cos(d)])
        np.testing.assert_allclose(got[[2, 5]], want, rtol=0, atol=1e-14)
        # ... and no coupling with the in-plane state either way.
        ip, op = [0, 1, 3, 4], [2, 5]
        np.testing.assert_allclose(got[ip], 0.0, rtol=0, atol=1e-14)
        np.testing.assert_allclose(P[np.ix_(op, ip)], 0.0, rtol=0, atol=1e-14)
        np.testing.assert_allclose(P[np.ix_(ip, op)], 0.0, rtol=0, atol=1e-14)
        # The dedicated helpers are the same blocks.
        np.testing.assert_allclose(np.asarray(yamanaka_ankersen_outofplane(f, f0)),
                                   P[np.ix_(op, op)], rtol=0, atol=1e-14)
        dt = F64(time_from_true_anomaly(orbit, f))
        np.testing.assert_allclose(
            np.asarray(yamanaka_ankersen_inplane(f, f0, dt - F64(time_from_true_anomaly(orbit, f0)),
                                                 F64(e), F64(orbit.k2))),
            P[np.ix_(ip, ip)], rtol=0, atol=1e-13 * np.max(np.abs(P)))
    # Check the [z~, z~'] solution itself against numerical integration of z~'' = -z~ (the
    # TH matrix's out-of-plane rows) over 2 revolutions: ~1e-13 integrator error.
    k2 = F64(orbit.k2)
    sol = solve_ivp(lambda ff, x: th_rhs(ff, x, np.zeros(3), e, k2), (f0, f0 + 13.0),
                    np.array([0.0, 0.0, z0, 0.0, 0.0, dz0]), method="DOP853", rtol=RTOL,
                    atol=1e-15)
    P = np.asarray(phi(orbit, f0 + 13.0, f0))
    assert rel_err(P[np.ix_([2, 5], [2, 5])] @ [z0, dz0], sol.y[[2, 5], -1]) <= 1e-10


# --------------------------------------------------------------------------------------------
# Tschauner-Hempel with control vs the time model under the same control
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("e", [0.3, 0.8])
def test_tschauner_hempel_control_gain(e):
    """A constant LVLH acceleration u enters x~'' as u / (k2^2 rho^3) (d2/df2 of rho x with
    dt/df = 1 / (k2 rho^2)); integrated in TH variables it must match the time-domain model
    with the same u. Short arc (a quarter period) through periapsis, where rho varies most."""
    orbit = orbit_(e, f0=F64(-0.8))
    k2, f0, T = F64(orbit.k2), F64(orbit.f0), F64(orbit.period)
    u = np.array([2e-5, -3e-5, 1.5e-5])  # m/s^2: displaces ~1e3..1e4 m over the arc
    t_end = 0.25 * T
    y0 = np.append(X0_LVLH, f0)
    atol = np.r_[np.full(3, 1e-15 * 500), np.full(3, 1e-15 * 0.02), 1e-15]
    sol_t = solve_ivp(ell_rhs_aug(orbit, u), (0.0, t_end), y0, method="DOP853", rtol=RTOL,
                      atol=atol)
    f_end = sol_t.y[6, -1]
    x0_th = np.asarray(lvlh_to_th(X0_LVLH, f0, e, k2))
    sol_f = solve_ivp(lambda ff, x: th_rhs(ff, x, u, e, k2), (f0, f_end), x0_th,
                      method="DOP853", rtol=RTOL, atol=1e-15 * np.max(np.abs(x0_th)))
    assert sol_t.success and sol_f.success
    got = np.asarray(th_to_lvlh(sol_f.y[:, -1], f_end, e, k2))
    want = sol_t.y[:6, -1]
    # 1e-9 relative: two integrations (~1e-13 each) and the end anomaly carried over from
    # the time integration (~1e-15 rad), amplified by |dx/df| / |x| = O(1).
    assert rel_err(got[:3], want[:3]) <= 1e-9
    assert rel_err(got[3:], want[3:]) <= 1e-9
    # The control dominates the free motion, so a wrong gain cannot pass.
    free = np.asarray(lvlh_samples(orbit, np.full(NSAMP, t_end), X0_LVLH)[0])[0]
    assert rel_err(free[:3], want[:3]) > 0.1
    # The gain itself: 1 / (k2^2 rho^3).
    for f in (0.0, 1.0, 3.0):
        rho = 1 + e * np.cos(f)
        np.testing.assert_allclose(tschauner_hempel_input_gain(f, e, k2),
                                   1.0 / (k2**2 * rho**3), rtol=10 * EPS)


# --------------------------------------------------------------------------------------------
# linearisation
# --------------------------------------------------------------------------------------------


def _nonlinear_lvlh_rate(x, rc, vc, mu):
    """Exact LVLH-state rate of a deputy under two-body gravity: d/dt inertial_to_lvlh along
    the two-body flow of chief and deputy (forward-mode derivative, no linearisation)."""
    dr, dv = lvlh_to_relative_inertial(rc, vc, x)
    rd, vd = rc + dr, vc + dv

    def acc(r):
        return -mu * r / jnp.linalg.norm(r) ** 3

    _, rate = jax.jvp(inertial_to_lvlh, (rc, vc, rd, vd), (vc, acc(rc), vd, acc(rd)))
    return rate


_lvlh_jacobian = jax.jit(jax.jacfwd(_nonlinear_lvlh_rate))


@pytest.mark.parametrize("e", [0.0, 0.3, 0.8])
def test_elliptic_lvlh_matrix_is_jacobian_of_two_body(e):
    """elliptic_lvlh_matrix (with chief_polar_rates) is the Jacobian at the chief of the exact
    relative two-body dynamics in LVLH (signs of w_dot, Coriolis and gravity gradient)."""
    orbit = orbit_(e)
    k2, p, mu = F64(orbit.k2), F64(orbit.p), F64(orbit.mu)
    for f in (F64(0.0), F64(1.0), F64(2.5), F64(4.0)):
        rc, vc = elements_to_state(orbit, f)
        J = np.asarray(_lvlh_jacobian(jnp.zeros(6), rc, vc, mu))
        rho, w, w_dot = chief_polar_rates(f, e, k2)
        A = np.asarray(elliptic_lvlh_matrix(p / rho, w, w_dot, mu))
        # Nondimensionalise with the chief's rate w: S A S^-1 / w with S = diag(1, 1/w)
        # has O(1) entries; both are exact up to rounding (~1e-15 relative, the inertial
        # positions ~4e7 m entering through differences): 1e-11.
        S = np.diag(np.r_[np.ones(3), np.full(3, 1.0 / float(w))])
        Si = np.diag(np.r_[np.ones(3), np.full(3, float(w))])
        np.testing.assert_allclose(S @ A @ Si / float(w), S @ J @ Si / float(w), rtol=0,
                                   atol=1e-11)
        # The rhs is A x + [0, u].
        x, u = X0_LVLH, np.array([1e-5, 2e-5, -3e-5])
        np.testing.assert_allclose(np.asarray(elliptic_lvlh_rhs(f, x, u, e, k2, p, mu)),
                                   A @ x + np.r_[np.zeros(3), u], rtol=1e-14, atol=1e-22)


def test_elliptic_model_tends_to_hcw():
    """At e = 0 the time-domain elliptic model is HCW with n = k2 (p = a): matrices equal; for
    small e the difference is O(e)."""
    base = orbit_(0.0, a=7.0e6)
    n = F64(base.mean_motion)
    H = np.asarray(hcw_matrix(n))
    for f in (F64(0.0), F64(1.0), F64(2.5), F64(5.0)):
        rho, w, w_dot = chief_polar_rates(f, 0.0, F64(base.k2))
        A = np.asarray(elliptic_lvlh_matrix(F64(base.p) / rho, w, w_dot, F64(base.mu)))
        # Same entries up to rounding: 3 n^2 as w^2 + 2 mu / r^3 and 0 as w^2 - mu / r^3
        # (cancellation of terms ~n^2): a few EPS times n^2 (and n for the Coriolis terms).
        np.testing.assert_allclose(A[3:, :3], H[3:, :3], rtol=0, atol=10 * EPS * n**2)
        np.testing.assert_allclose(A[3:, 3:], H[3:, 3:], rtol=0, atol=10 * EPS * n)
        np.testing.assert_array_equal(A[:3], H[:3])
        x, u = X0_LVLH, np.array([1e-5, 2e-5, -3e-5])
        np.testing.assert_allclose(
            np.asarray(elliptic_lvlh_rhs(f, x, u, 0.0, F64(base.k2), F64(base.p), F64(base.mu))),
            np.asarray(hcw_rhs(0.0, x, u, n)), rtol=0, atol=10 * EPS * n**2 * 1e3 + 1e-20)
    # Small e: ||A(e) - A_HCW|| in units of n^2 is O(e) (and of order e, not zero).
    diffs = []
    for e in (1e-2, 1e-4):
        orb = orbit_(e, a=7.0e6)
        rho, w, w_dot = chief_polar_rates(F64(1.0), e, F64(orb.k2))
        A = np.asarray(elliptic_lvlh_matrix(F64(orb.p) / rho, w, w_dot, F64(orb.mu)))
        diffs.append(np.max(np.abs(A[3:, :3] - H[3:, :3])) / n**2)
    assert 0.1 * 1e-2 < diffs[0] < 20 * 1e-2
    # Linear in e: the ratio over two decades of e is 100 up to the O(e^2) terms, i.e. a
    # relative correction of a few times e = 1e-2 (measured 2.3 %): 95..105.
    assert 95.0 < diffs[0] / diffs[1] < 105.0
