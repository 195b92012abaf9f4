"""Trajectories of intercept solutions (frame "inertial"): one burn between two J2 coasts.

`Impulse`: an instantaneous velocity change dv at t_b (Tan et al. 2011, §1). `FiniteBurn`: a
constant-thrust burn from t_s to t_e along a collocated direction (§2.5), its states the LGL
state polynomial over the burn. The coasts before and after are evaluated by the library's J2
propagation (`jaxlpm.dynamics.propagation.propagate`, Dopri8): the state at t is the coast
from the initial state (t before the burn) or from the state after it (t after).

Earth-centred inertial frame, z along the rotation axis (equatorial); SI units (m, m/s,
m/s^2, s, kg, N). Times are seconds since t = 0 of the intercept problem. The state is
right-continuous at an impulse: at t = t_b it is the state after the burn.

Neither family estimates costates: `costate(t)` is NaN (6,).

`burn()` describes the burn as an independent integrator flies it (`Burn`: the interval, the
direction as a propagator calls it, the engine, the impulse), for `jaxlpm.verify.fly`.
"""

from dataclasses import dataclass, replace
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp

from ..collocation import Grid
from ..collocation.padded import capacity, grid_rows, pad_grid, pad_rows
from ..dynamics.propagation import propagate
from .collocated import control_interpolant, take_rows

# A concrete burn's grid lgl(n) is padded to 21 points (2^k + 1 above: 41, ...) where one
# program should serve every n (the solver's solve, the flight's plan): tan2011 solves 5, 10
# and 20 points.
PAD_CAPACITY = 21


class Burn(NamedTuple):
    """A burn as a flight flies it: thrust F (N) along `control` (a unit direction of time,
    inertial; None: no continuous thrust) from t_start to t_end (s) with mass m0 (kg) at
    t_start and mass flow mass_rate (kg/s), then `impulse` (3,) (m/s) added to the velocity
    at t_end."""

    t_start: jax.Array
    t_end: jax.Array
    control: Any
    thrust: jax.Array
    mass: jax.Array
    mass_rate: jax.Array
    impulse: jax.Array


def _coast_from(start, elapsed, mu, j2, r_eq):
    """[r, v] (m, m/s) after coasting `start` for `elapsed` >= 0 s under two-body + J2."""
    return propagate(start, elapsed, mu, j2, r_eq)[0]


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class Impulse:
    """One impulse between two J2 coasts.

    state0       [r, v] (6,) at t = 0 (m, m/s)
    t_burn       t_b (s)
    burn_state   [r, v] (6,) just before the burn (m, m/s)
    dv           the impulse (3,) (m/s)
    end_state    [r, v] (6,) at t_f (m, m/s), the coast's end by the solver
    duration     t_f (s)
    mu, j2, r_eq gravity of the coasts (m^3/s^2, -, m)

    Nodes: `times` = [t_b] with zero `node_controls` (an impulse is no acceleration: the
    impulse is `dv`); `state_times` = [0, t_b, t_f] with `node_states` the initial state, the
    state after the burn and the final state.
    """

    state0: jax.Array
    t_burn: jax.Array
    burn_state: jax.Array
    dv: jax.Array
    end_state: jax.Array
    duration: jax.Array
    mu: jax.Array
    j2: jax.Array
    r_eq: jax.Array

    @property
    def grid(self):
        """None: an impulsive solution has no collocation grid."""
        return None

    @property
    def after_burn(self):
        """[r, v] (6,) just after the burn (m, m/s)."""
        return self.burn_state + jnp.concatenate([jnp.zeros_like(self.dv), self.dv], -1)

    @property
    def times(self):
        return self.t_burn[..., None]

    @property
    def node_controls(self):
        return jnp.zeros(self.t_burn.shape + (1, 3), self.dv.dtype)

    @property
    def state_times(self):
        return jnp.stack([jnp.zeros_like(self.t_burn), self.t_burn, self.duration], -1)

    @property
    def node_states(self):
        return jnp.stack([self.state0, self.after_burn, self.end_state], -2)

    def state(self, t):
        """[r, v] at t (s): the coast from state0 before t_b, from the post-burn state after."""
        before = t < self.t_burn
        start = jnp.where(before, self.state0, self.after_burn)
        return _coast_from(start, jnp.where(before, t, t - self.t_burn), self.mu, self.j2,
                           self.r_eq)

    def control(self, t):
        """Zero (m/s^2): the impulse is no acceleration (`dv`, `delta_v`)."""
        return jnp.zeros(3, self.dv.dtype) + 0.0 * t

    def costate(self, t):
        """NaN (6,): no costates are estimated."""
        return jnp.full(6, jnp.nan, self.dv.dtype) + 0.0 * t

    def delta_v(self):
        """|dv| (m/s)."""
        return jnp.linalg.norm(self.dv, axis=-1)

    def flight_control(self):
        """None: no continuous thrust (the impulse is in `burn()`)."""
        return None

    def burn(self) -> Burn:
        zero = jnp.zeros_like(self.t_burn)
        return Burn(self.t_burn, self.t_burn, None, zero, zero + 1.0, zero, self.dv)


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class FiniteBurn:
    """A constant-thrust burn between two J2 coasts.

    grid             the LGL `Grid` of the burn arc (n points: the paper's "n nodes")
    state0           [r, v] (6,) at t = 0 (m, m/s)
    t_start, t_end   the burn's start t_s and end t_e (s)
    node_states      [r, v] (n, 6) at the grid's points mapped to [t_s, t_e] (m, m/s)
    node_directions  (n, 3) unit thrust directions there
    thrust, mass, mass_rate  F (N), m0 at t_s (kg), F / (isp g0) (kg/s)
    duration         t_f (s)
    mu, j2, r_eq     gravity of the coasts

    During the burn the state is the LGL state polynomial and the control the thrust
    acceleration F / m(t) u_hat(t), m(t) = m0 - mass_rate (t - t_s), u_hat the barycentric
    interpolant of the nodal directions renormalised to unit length (what the engine flies);
    zero on the coasts. The coast after the burn starts from the last node's state.
    """

    NODE_FIELDS = ("node_states", "node_directions")

    grid: Grid
    state0: jax.Array
    t_start: jax.Array
    t_end: jax.Array
    node_states: jax.Array
    node_directions: jax.Array
    thrust: jax.Array
    mass: jax.Array
    mass_rate: jax.Array
    duration: jax.Array
    mu: jax.Array
    j2: jax.Array
    r_eq: jax.Array

    @property
    def times(self):
        """The LGL points of the burn (s)."""
        width = (self.t_end - self.t_start)[..., None]
        return self.t_start[..., None] + 0.5 * width * (self.grid.points + 1.0)

    @property
    def node_masses(self):
        """Mass (kg) at `times`."""
        return self.mass[..., None] - self.mass_rate[..., None] * (
            self.times - self.t_start[..., None])

    @property
    def node_controls(self):
        """Thrust accelerations F / m u_hat (m/s^2) at `times`."""
        return (self.thrust[..., None] / self.node_masses)[..., None] * self.node_directions

    @property
    def state_times(self):
        return self.times

    def _tau(self, t):
        return 2.0 * (t - self.t_start) / (self.t_end - self.t_start) - 1.0

    def state(self, t):
        """[r, v] at t (s): the coast before t_s, the state polynomial during the burn, the
        coast from the burn's end state after t_e."""
        before, after = t < self.t_start, t > self.t_end
        burning = self.grid.interpolate_state(self.node_states,
                                              jnp.clip(self._tau(t), -1.0, 1.0))
        start = jnp.where(before, self.state0, self.node_states[-1])
        elapsed = jnp.where(before, t, jnp.where(after, t - self.t_end, 0.0))
        coast = _coast_from(start, elapsed, self.mu, self.j2, self.r_eq)
        return jnp.where(before | after, coast, burning)

    def control(self, t):
        """F / m(t) u_hat(t) (m/s^2) during the burn, zero on the coasts."""
        mass = self.mass - self.mass_rate * (t - self.t_start)
        firing = (t >= self.t_start) & (t <= self.t_end)
        return jnp.where(firing, self.thrust / mass * self.flight_control()(t), 0.0)

    def costate(self, t):
        """NaN (6,): no costates are estimated."""
        return jnp.full(6, jnp.nan, self.node_states.dtype) + 0.0 * t

    def delta_v(self):
        """int |u| dt = isp g0 ln(m0 / m_f) (m/s): the rocket equation, exact for a unit
        direction at constant thrust and mass flow (isp g0 = F / mass_rate)."""
        spent = self.mass_rate * (self.t_end - self.t_start)
        return -self.thrust / self.mass_rate * jnp.log1p(-spent / self.mass)

    def flight_control(self):
        """The unit thrust direction u_hat(t) (t in s) as a propagator calls it."""
        return control_interpolant(self.grid, self.node_directions, self.t_start, self.t_end,
                                   1.0, "time")

    def padded(self) -> "FiniteBurn":
        """This burn on lgl(n) with its grid a `PaddedGrid` of `capacity(n, PAD_CAPACITY)`
        points and its node rows in the padded layout (host arrays; concrete, one burn): one
        compiled program serves every grid up to the capacity."""
        padded = pad_grid(self.grid.n, capacity(self.grid.n, PAD_CAPACITY))
        return replace(self, grid=padded, **{k: pad_rows(getattr(self, k), padded.n)
                                             for k in self.NODE_FIELDS})

    def unpadded(self, grid: Grid) -> "FiniteBurn":
        """The inverse of `padded`: this burn on a `PaddedGrid` of `grid` (= lgl(n)) as the
        burn on `grid`, its node rows gathered on the host (no compiled program)."""
        rows = grid_rows(grid.n, self.grid.n)
        return replace(self, grid=grid, **{k: take_rows(getattr(self, k), rows)
                                           for k in self.NODE_FIELDS})

    def burn(self) -> Burn:
        return Burn(self.t_start, self.t_end, self.flight_control(), self.thrust, self.mass,
                    self.mass_rate, jnp.zeros_like(self.node_directions[..., 0, :]))
