"""Truth checks: fly an interpolated control through a dynamics model with a tight integrator.

The control is the physical acceleration u (m/s^2, LVLH axes), barycentric Lagrange over the
solution's nodes in the chief's true anomaly. It is packed into a fixed-size, zero-padded
`ControlInterpolant` so one compiled propagator serves every node count N.

Integrator: diffrax Dopri8 (8th-order Dormand-Prince, adaptive, PID step control) at
rtol = atol = 1e-12 (states scaled to O(1) internally), through `solve_ode` (a failure is
ok = False, never an exception). Models: (a) linearised elliptic LVLH equations in time;
(b) nonlinear two-body (+ J2) chief and deputy, differenced in the chief's LVLH frame. The
chief's anomaly is integrated beside the state (d/dt = |h| / r^2: the true anomaly of a
Keplerian chief, the regularised anomaly of a J2 one), so no Kepler solve sits inside the
right-hand side.
"""

from dataclasses import dataclass

import diffrax
import jax
import jax.numpy as jnp

from .._validation import require_x64
from ..collocation import barycentric_interpolate
from ..constants import R_EARTH
from ..dynamics import elliptic_lvlh_rhs, gravity_acceleration, relative_inertial_rhs
from ..dynamics.chief import anomaly_rate
from ..dynamics.propagation import solve_ode
from ..orbits import elements_to_state, lvlh_to_relative_inertial, relative_inertial_to_lvlh
from ..status import Status

PAD_TO = 129          # largest node count one compiled propagator serves
_FAR = 10.0           # padded support points sit outside [-1, 1] with zero weight
RTOL = ATOL = 1e-12


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class ControlInterpolant:
    """u(f) = barycentric interpolant v(f) of `values` (PAD_TO, 3) on `tau` in [f0, fT]; with
    magnitude > 0 the interpolated direction at that magnitude, magnitude v / |v| (a
    constant-thrust engine flies the interpolated direction, Duan & Dong 2011 §4)."""

    tau: jax.Array
    bary: jax.Array
    values: jax.Array
    f0: jax.Array
    fT: jax.Array
    magnitude: jax.Array = 0.0

    def __call__(self, f):
        t = 2.0 * (f - self.f0) / (self.fT - self.f0) - 1.0
        v = barycentric_interpolate(self.tau, self.bary, self.values, t)
        norm = jnp.linalg.norm(v)
        unit = v / jnp.where(norm > 0.0, norm, 1.0)
        return jnp.where(self.magnitude > 0.0, self.magnitude * unit, v)


def control_interpolant(solution, pad_to: int = PAD_TO, magnitude=0.0) -> ControlInterpolant:
    """The solution's nodal control as a padded interpolant (works on batched solutions too);
    magnitude > 0 (m/s^2) renormalises the interpolated control to that constant magnitude."""
    g = solution.grid
    n = g.points.shape[-1]
    if n > pad_to:
        raise ValueError(f"at most {pad_to} nodes can be propagated, got {n}")
    pad = pad_to - n
    lead = solution.node_controls.shape[:-2]

    def padded(x, value):
        widths = [(0, 0)] * (x.ndim - 1) + [(0, pad)]
        return jnp.pad(x, widths, constant_values=value)

    vals = jnp.pad(solution.node_controls, [(0, 0)] * len(lead) + [(0, pad), (0, 0)])
    tau = jnp.broadcast_to(padded(g.points, _FAR), lead + (pad_to,))
    bary = jnp.broadcast_to(padded(g.point_bary, 0.0), lead + (pad_to,))
    f0, fT = solution.anomaly_interval()
    return ControlInterpolant(tau, bary, vals, f0, fT,
                              jnp.broadcast_to(jnp.asarray(magnitude, vals.dtype), lead))


def _integrate(rhs, y0, scale, t1, ts):
    """Integrate dy/dt = rhs(t, y) from 0 to t1 in scaled variables y/scale; save at ts.
    Returns (ys, ok); ok False when `solve_ode` failed (never raises)."""
    ys, status = solve_ode(lambda t, y: rhs(t, y * scale) / scale, y0 / scale, 0.0, t1,
                           diffrax.SaveAt(ts=ts), RTOL, ATOL, 200_000)
    return ys * scale, status == Status.SUCCESS


def _save_times(duration, n_save):
    return jnp.linspace(0.0, 1.0, n_save) * duration


def propagate_linear(orbit, x0, duration, control: ControlInterpolant, n_save: int = 401):
    """Fly u through the linearised elliptic LVLH equations in time (Yamanaka-Ankersen eq. 2).

    Returns (times (n_save,), LVLH states (n_save, 6), ok). x0 in m, m/s at the orbit's epoch.
    ok is False (never an exception) when the integration failed: step limit or non-finite
    input (then the states are zeros or non-finite). ValueError unless float64 is enabled.
    """
    require_x64()
    e, k2, p, mu = orbit.e, orbit.k2, orbit.p, orbit.mu

    def rhs(t, y):
        f = y[6]
        return jnp.concatenate([elliptic_lvlh_rhs(f, y[:6], control(f), e, k2, p, mu),
                                (k2 * (1.0 + e * jnp.cos(f)) ** 2)[None]])

    scale = _state_scale(x0, orbit)
    y0 = jnp.concatenate([x0, jnp.atleast_1d(orbit.f0 + 0.0 * e)])
    ts = _save_times(duration, n_save)
    ys, ok = _integrate(rhs, y0, jnp.concatenate([scale, jnp.ones(1)]), duration, ts)
    return ts, ys[:, :6], ok


def propagate_nonlinear(orbit, x0, duration, control: ControlInterpolant, n_save: int = 401,
                        j2=0.0, r_eq=R_EARTH):
    """Fly u through nonlinear relative motion: chief and deputy integrated inertially (the
    deputy as its exact offset from the chief) under two-body gravity, plus J2 on both when
    j2 != 0, differenced in the chief's LVLH frame (for a J2 chief: its exact rotating frame).
    The control's anomaly is the chief's regularised anomaly, d/dt = |h| / r^2 (the true
    anomaly of a Keplerian chief). The chief starts on `orbit`'s state at its epoch.

    Returns (times (n_save,), LVLH states (n_save, 6), ok), ok as in `propagate_linear`.
    """
    require_x64()
    mu = orbit.mu
    rc, vc = elements_to_state(orbit)
    a_chief = gravity_acceleration(rc, mu, j2, r_eq)
    dr, dv = lvlh_to_relative_inertial(rc, vc, x0, a_chief)

    def rhs(t, y):
        rate = relative_inertial_rhs(y[:12], control(y[12]), mu, j2, r_eq)
        return jnp.concatenate([rate, anomaly_rate(y[:6])[None]])

    y0 = jnp.concatenate([rc, vc, dr, dv, jnp.atleast_1d(orbit.f0 + 0.0 * orbit.e)])
    rel = _state_scale(x0, orbit)
    scale = jnp.concatenate([jnp.full(3, orbit.a), jnp.full(3, orbit.a * orbit.mean_motion),
                             rel, jnp.ones(1)])
    ts = _save_times(duration, n_save)
    ys, ok = _integrate(rhs, y0, scale, duration, ts)

    def to_lvlh(y):
        acc = gravity_acceleration(y[:3], mu, j2, r_eq)
        return relative_inertial_to_lvlh(y[:3], y[3:6], y[6:9], y[9:12], acc)

    return ts, jax.vmap(to_lvlh)(ys), ok


def _state_scale(x0, orbit):
    """Length scale max(|r0|, 1 m) and its velocity scale n * length, for scaled integration."""
    length = jnp.maximum(jnp.linalg.norm(x0[:3]), 1.0)
    return jnp.concatenate([jnp.full(3, length), jnp.full(3, length * orbit.mean_motion)])


def terminal_error(states, target):
    """[|position error| (m), |velocity error| (m/s)] of the final state against the target."""
    d = states[-1] - target
    return jnp.stack([jnp.linalg.norm(d[:3]), jnp.linalg.norm(d[3:])])
