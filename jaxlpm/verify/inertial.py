"""Independent truth integrator for one spacecraft in the inertial frame: two-body + J2 gravity
with an optional constant-thrust arc of interpolated direction.

Frame: Earth-centred inertial, z along the Earth's rotation axis (equatorial; the frame of
`jaxlpm.dynamics.gravity`). SI units: m, m/s, kg, s, N. The state is y = [r, v, m] with

    dr/dt = v,   dv/dt = a_grav(r) + (F / m) u_hat(t),   dm/dt = -mdot,

mdot = F / (Isp g0) during a burn (Tsiolkovsky's constant mass flow), F = mdot = 0 for a
coast. u_hat(t) is the barycentric interpolant of the nodal directions, renormalised to unit
length (`ControlInterpolant` with magnitude 1: the constant-thrust engine flies the
interpolated direction).

This is the check on the solvers, so it shares none of their integration choices: diffrax
Tsit5 (Tsitouras' 5(4) pair) instead of Dopri8, rtol = atol = 1e-13 instead of 1e-12, fixed
scales (10^7 m, sqrt(mu / 10^7 m), the initial mass) instead of the initial radius. Only the
gravity model (`inertial_rhs`) and the non-raising diffrax call (`solve_ode`, given this
module's solver and tolerances) are shared; tests/test_tan2011.py checks it against scipy's
DOP853 on a NumPy right-hand side.
"""

import diffrax
import jax.numpy as jnp

from .._validation import require_x64
from ..constants import J2_EARTH, MU_EARTH, R_EARTH
from ..dynamics.gravity import inertial_rhs
from ..dynamics.propagation import INDEPENDENT, solve_ode
from ..status import Status
from ..solution import ControlInterpolant

LENGTH = 1.0e7            # m: the integrator's length scale


def direction_interpolant(grid, directions, t_start, duration) -> ControlInterpolant:
    """u_hat(t) (unit, inertial) from nodal directions (grid.n, 3) at the grid's points mapped
    to [t_start, t_start + duration] (s): barycentric interpolation, renormalised."""
    return ControlInterpolant(grid.points, grid.point_bary, jnp.asarray(directions), t_start,
                              t_start + duration, jnp.asarray(1.0))


def fly(state, mass, t0, t1, control: ControlInterpolant = None, thrust=0.0, mass_rate=0.0,
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

    saveat = diffrax.SaveAt(t1=True) if ts is None else diffrax.SaveAt(ts=ts)
    ys, status = solve_ode(rhs, y0 / scale, t0, t1, saveat, INDEPENDENT)
    ys = ys * scale
    return (ys[-1] if ts is None else ys), status == Status.SUCCESS


def fly_finite_burn(problem, solution, n_save: int = 0):
    """Fly a `FiniteBurnSolution` of `problem` (`FiniteBurnProblem`) end to end with this
    integrator: the coast of state0 from 0 to t_start, the burn of the renormalised
    interpolated direction for `duration` (thrust, mass flow mdot), the coast to t_f.

    Returns (miss |r(t_f) - r_target| (m), final [r, v, m], ok, burn samples): ok is False
    when any of the three flights failed (`fly`); with n_save > 0 the burn's samples (times
    (n_save,), states (n_save, 7)), else None.
    """
    ip = problem.intercept
    gravity = (ip.mu, ip.j2, ip.r_eq)
    t_s, t_e = solution.t_start, solution.t_start + solution.duration
    pre, ok0 = fly(ip.state0, problem.mass, 0.0, t_s, None, 0.0, 0.0, *gravity)
    control = direction_interpolant(solution.grid, solution.node_directions, t_s,
                                    solution.duration)
    end, ok1 = fly(pre[:6], pre[6], t_s, t_e, control, problem.thrust, problem.mass_rate,
                   *gravity)
    final, ok2 = fly(end[:6], end[6], t_e, ip.t_f, None, 0.0, 0.0, *gravity)
    samples = None
    if n_save:
        ts = jnp.linspace(t_s, t_e, n_save)
        states, _ = fly(pre[:6], pre[6], t_s, t_e, control, problem.thrust, problem.mass_rate,
                        *gravity, ts=ts)
        samples = (ts, states)
    return jnp.linalg.norm(final[:3] - ip.r_target), final, ok0 & ok1 & ok2, samples
