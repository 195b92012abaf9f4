"""Independent truth integrator for one spacecraft in the inertial frame: two-body + J2 gravity
with an optional constant-thrust arc of interpolated direction.

Frame: Earth-centred inertial, z along the Earth's rotation axis (equatorial; the frame of
`jaxlpm.dynamics.gravity`). SI units: m, m/s, kg, s, N. The state is y = [r, v, m] with

    dr/dt = v,   dv/dt = a_grav(r) + (F / m) u_hat(t),   dm/dt = -mdot,

mdot = F / (Isp g0) during a burn (Tsiolkovsky's constant mass flow), F = mdot = 0 for a
coast. u_hat(t) is the barycentric interpolant of the nodal directions, renormalised to unit
length (a `jaxlpm.solution.ControlInterpolant` with magnitude 1, the `flight_control()` of a
`FiniteBurn`: the constant-thrust engine flies the interpolated direction). `fly_burn` flies
a whole intercept (coast, burn or impulse, coast); `jaxlpm.verify.fly` calls it for the
solutions in the inertial frame.

This is the check on the solvers, so it shares none of their integration choices: diffrax
Tsit5 (Tsitouras' 5(4) pair) instead of Dopri8, rtol = atol = 1e-13 instead of 1e-12, fixed
scales (10^7 m, sqrt(mu / 10^7 m), the initial mass) instead of the initial radius. Only the
gravity model (`inertial_rhs`) and the non-raising diffrax call (`solve_ode`, given this
module's solver and tolerances) are shared; tests/test_tan2011.py checks it against scipy's
DOP853 on a NumPy right-hand side.
"""

import jax.numpy as jnp

from .._validation import require_x64
from ..constants import J2_EARTH, MU_EARTH, R_EARTH
from ..dynamics.gravity import inertial_rhs
from ..dynamics.propagation import INDEPENDENT, solve_ode
from ..status import Status
from ..solution import Burn

LENGTH = 1.0e7            # m: the integrator's length scale


def fly(state, mass, t0, t1, control=None, thrust=0.0, mass_rate=0.0,
        mu=MU_EARTH, j2=J2_EARTH, r_eq=R_EARTH, ts=None):
    """Integrate [r (m), v (m/s)] and the mass (kg) from t0 to t1 (s): a coast when `control`
    is None, else a burn of `thrust` (N) along control(t) with mass flow `mass_rate` (kg/s).

    Returns (states [r, v, m] (7,) at t1, or (len(ts), 7) at the times ts in [t0, t1], ok);
    ok is False (never an exception) when the integration failed (`solve_ode`: step limit or
    non-finite input or states). ValueError unless float64 is enabled.
    """
    require_x64()
    y0 = jnp.concatenate([jnp.asarray(state, jnp.float64), jnp.atleast_1d(mass * 1.0)])
    speed = jnp.sqrt(mu / LENGTH)
    scale = jnp.concatenate([jnp.full(3, LENGTH), jnp.full(3, speed), y0[6:]])

    def rhs(t, y):
        y = y * scale
        u = (jnp.zeros(3) if control is None else thrust / y[6] * control(t))
        rate = inertial_rhs(y[:6], u, mu, j2, r_eq)
        return jnp.concatenate([rate, -jnp.atleast_1d(mass_rate * 1.0)]) / scale

    ys, status = solve_ode(rhs, y0 / scale, t0, t1, ts, INDEPENDENT)
    ys = ys * scale
    return (ys[-1] if ts is None else ys), status == Status.SUCCESS


def fly_burn(state0, burn: Burn, t_f, ts, mu=MU_EARTH, j2=J2_EARTH, r_eq=R_EARTH):
    """Fly an intercept from t = 0 to t_f (s) with this integrator: the coast of state0
    [r, v] (m, m/s) to burn.t_start, the burn of thrust burn.thrust (N) along burn.control
    (renormalised direction, inertial) with mass flow burn.mass_rate (kg/s) to burn.t_end (no
    burn arc when burn.control is None), burn.impulse (m/s) added to the velocity at t_end,
    the coast to t_f. The mass starts at burn.mass (kg).

    Returns (states [r, v, m] (len(ts), 7) at the times ts in [0, t_f]: before t_start on the
    first coast, from t_start to before t_end on the burn, from t_end on the last coast (after
    the impulse); ok: every flight succeeded (`fly`)).
    """
    gravity = (mu, j2, r_eq)
    ts = jnp.asarray(ts)

    def arc(y, t0, t1, control=None, thrust=0.0, mass_rate=0.0):
        """States at ts clipped to [t0, t1], then the state at t1."""
        at = jnp.concatenate([jnp.clip(ts, t0, t1), jnp.atleast_1d(t1)])
        ys, ok = fly(y[:6], y[6], t0, t1, control, thrust, mass_rate, *gravity, ts=at)
        return ys[:-1], ys[-1], ok

    start = jnp.concatenate([jnp.asarray(state0), jnp.atleast_1d(burn.mass * 1.0)])
    states0, y, ok = arc(start, 0.0, burn.t_start)
    states1 = states0
    if burn.control is not None:
        states1, y, ok1 = arc(y, burn.t_start, burn.t_end, burn.control, burn.thrust,
                              burn.mass_rate)
        ok = ok & ok1
    y = y + jnp.concatenate([jnp.zeros(3), burn.impulse, jnp.zeros(1)])
    states2, _, ok2 = arc(y, burn.t_end, t_f)
    ts = ts[:, None]
    states = jnp.where(ts < burn.t_start, states0, jnp.where(ts < burn.t_end, states1, states2))
    return states, ok & ok2
