"""Tests of jaxlpm.dynamics.propagation (two-body + J2 coast by diffrax Dopri8) and of its
non-raising integrator `solve_ode` (also under the J2 chief, `jaxlpm.dynamics.chief`).

Independent reference: scipy's DOP853 at rtol 1e-13 on a NumPy J2 right-hand side written
here from Curtis (2014) ch. 10; the J2 energy integral; central finite differences.
"""

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from jaxlpm.constants import J2_EARTH, MU_EARTH, R_EARTH
from jaxlpm.dynamics.chief import j2_chief, j2_final_anomaly
from jaxlpm.dynamics.gravity import j2_potential
from jaxlpm.dynamics.propagation import Integrator, propagate, solve_ode
from jaxlpm.orbits import KeplerOrbit, elements_to_state
from jaxlpm.status import Status

DEG = np.pi / 180.0
TWO_DAYS = 172800.0


def _rhs_numpy(t, y):
    r = y[:3]
    rn = np.linalg.norm(r)
    k = 1.0 - 5.0 * (r[2] / rn) ** 2
    a_j2 = -1.5 * MU_EARTH * J2_EARTH * R_EARTH**2 / rn**5 * np.array(
        [r[0] * k, r[1] * k, r[2] * (k + 2.0)])
    return np.r_[y[3:], -MU_EARTH * r / rn**3 + a_j2]


def _initial(inclination_deg):
    """tan2011's high-eccentricity orbit (a = 26792 km, e = 0.575), tilted to exercise the
    z terms of J2."""
    orbit = KeplerOrbit(a=26792.199e3, e=0.575, i=inclination_deg * DEG, raan=0.3,
                        argp=1.963 * DEG, f0=359.974 * DEG)
    return np.concatenate([np.asarray(v) for v in elements_to_state(orbit)])


_prop = jax.jit(propagate)


@pytest.mark.parametrize("inclination", [0.0, 35.0])
def test_two_days_against_dop853(inclination):
    x0 = _initial(inclination)
    ref = solve_ivp(_rhs_numpy, (0.0, TWO_DAYS), x0, method="DOP853", rtol=1e-13,
                    atol=1e-8).y[:, -1]
    y, ok = _prop(x0, TWO_DAYS)
    assert bool(ok)
    # two integrators at rtol 1e-12 / 1e-13 over ~4 revolutions of a 4e7 m orbit: their global
    # errors are ~1e-12 per step over ~1e3 steps, i.e. millimetres; 5 cm is far below the
    # metre-level misses reported by tan2011 and catches any model or scaling error (J2 moves
    # this orbit by kilometres in two days)
    assert np.linalg.norm(np.asarray(y[:3]) - ref[:3]) < 0.05
    assert np.linalg.norm(np.asarray(y[3:]) - ref[3:]) < 0.05 * 1e-3
    # J2 really acts: the two-body coast ends kilometres away
    y_kepler, _ = _prop(x0, TWO_DAYS, MU_EARTH, 0.0)
    assert np.linalg.norm(np.asarray(y_kepler[:3]) - ref[:3]) > 1e3


def test_energy_conserved_and_saved_times():
    x0 = _initial(35.0)
    ts = np.linspace(0.0, TWO_DAYS, 9)
    ys, ok = jax.jit(propagate)(x0, TWO_DAYS, ts=ts)
    ys = np.asarray(ys)
    assert bool(ok) and ys.shape == (9, 6)
    np.testing.assert_allclose(ys[0], x0, rtol=4e-16)   # scaling round trip: a few ulps
    energy = [0.5 * y[3:] @ y[3:] - MU_EARTH / np.linalg.norm(y[:3])
              - float(j2_potential(y[:3], MU_EARTH, J2_EARTH, R_EARTH)) for y in ys]
    # specific energy ~ -7.4e6 m^2/s^2; the integrator's 1e-12 tolerance allows ~1e-11 drift
    assert np.ptp(energy) < 1e-9 * abs(energy[0])


def test_gradient_of_final_position():
    """d r(t_f) / d v0 by reverse mode through diffrax against central differences (step 1 mm/s
    on 7 km/s: truncation ~(h/v)^2 ~ 1e-14 relative, rounding ~ integrator noise 1e-12 |r| / h
    ~ 4e-2 m per m/s against derivatives ~1e5 s: 1e-6 relative bounds both)."""
    x0 = _initial(35.0)
    dur = 0.5 * TWO_DAYS
    final_position = lambda v: propagate(jax.numpy.concatenate([x0[:3], v]), dur)[0][:3]
    jac = np.asarray(jax.jit(jax.jacrev(final_position))(x0[3:]))
    h = 1e-3
    fd = np.stack([(np.asarray(_prop(np.r_[x0[:3], x0[3:] + h * e], dur)[0][:3])
                    - np.asarray(_prop(np.r_[x0[:3], x0[3:] - h * e], dur)[0][:3])) / (2 * h)
                   for e in np.eye(3)], 1)
    assert np.max(np.abs(jac - fd)) < 1e-6 * np.max(np.abs(fd))


# ~41 Dopri8 steps per revolution at rtol 1e-12 (measured), so 3000 revolutions need ~1.2e5
# steps: past the 100 000-step limit of `propagate` and of the J2 chief (rtol 1e-13)
LEO = KeplerOrbit(a=jnp.asarray(7000e3), e=jnp.asarray(0.01), i=jnp.asarray(0.5),
                  raan=jnp.asarray(0.2), argp=jnp.asarray(0.3), f0=jnp.asarray(0.1))
MANY_REVOLUTIONS = 3000.0 * float(LEO.period)


def test_step_limit_gives_not_ok_instead_of_raising():
    x0 = np.concatenate([np.asarray(v) for v in elements_to_state(LEO)])
    _, ok = _prop(x0, MANY_REVOLUTIONS)
    assert not bool(ok)
    _, ok = jax.jit(j2_final_anomaly)(LEO, MANY_REVOLUTIONS, J2_EARTH, R_EARTH)
    assert not bool(ok)


def test_solve_ode_status_codes():
    """diffrax's result mapped to `Status` on y'' = -y (period 2 pi, y(2 pi) = y(0))."""
    def run(y0, t1, max_steps=1000, w=1.0):
        rhs = lambda t, y: jnp.stack([y[1], -w * y[0]])
        return jax.jit(solve_ode, static_argnums=(0, 4, 5))(
            rhs, y0, 0.0, t1, None, Integrator(1e-12, 1e-12, max_steps))

    y0, period = jnp.array([1.0, 0.0]), 2.0 * np.pi
    ys, status = run(y0, period)
    assert int(status) == Status.SUCCESS
    # rtol 1e-12 per step over ~20 steps: the global error is ~1e-11; 1e-9 catches a wrong
    # time span or a blanked right-hand side (O(1) errors)
    np.testing.assert_allclose(ys[-1], y0, atol=1e-9)
    assert int(run(y0, 100.0 * period, max_steps=3)[1]) == Status.MAX_ITERATIONS
    ys, status = run(y0.at[0].set(jnp.nan), period)       # skipped: zeros, flagged
    assert int(status) == Status.NONFINITE and not np.any(np.asarray(ys))
    assert int(run(y0, jnp.nan)[1]) == Status.NONFINITE
    assert int(run(y0, period, w=jnp.nan)[1]) == Status.NONFINITE


def _max_relative_difference(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return np.max(np.abs(a - b)) / np.max(np.abs(b))


def test_vmapped_batch_flags_the_nan_member_only():
    """One NaN state in a vmapped coast: ok False for it, the others as if flown alone.
    Members take their own adaptive steps; vectorised evaluation only reorders rounding
    (measured: bit-identical here, 6e-14 for the chief below), so 1e-12, the integrator's
    tolerance, bounds the difference; a mixed-up or blanked member is off by O(1)."""
    batch = np.stack([_initial(35.0), _initial(35.0), _initial(10.0)])
    batch[1, 2] = np.nan
    ys, ok = jax.jit(jax.vmap(propagate, in_axes=(0, None)))(batch, 36000.0)
    assert np.asarray(ok).tolist() == [True, False, True]
    for k in (0, 2):
        assert _max_relative_difference(ys[k], _prop(batch[k], 36000.0)[0]) < 1e-12


def test_vmapped_j2_chief_with_nan_inclination():
    """A NaN inclination in a vmapped J2 chief (traced, so no Python check sees it): ok False
    and NaN-free samples for that member, the others as if integrated alone (1e-12, as
    above). diffrax's default throw=True raised here after tens of seconds."""
    def chief(i):
        orbit = LEO.replace(i=i)
        s_f, ok_f = j2_final_anomaly(orbit, 2.0 * orbit.period, J2_EARTH, R_EARTH)
        samples, ok_c = j2_chief(orbit, s_f, jnp.linspace(0.0, 1.0, 5), J2_EARTH, R_EARTH)
        return samples.state, ok_f & ok_c

    incl = jnp.array([0.5, jnp.nan, 0.7])
    states, ok = jax.jit(jax.vmap(chief))(incl)
    assert np.asarray(ok).tolist() == [True, False, True]
    assert np.all(np.isfinite(states))
    alone = jax.jit(chief)
    for k in (0, 2):
        assert _max_relative_difference(states[k], alone(incl[k])[0]) < 1e-12
