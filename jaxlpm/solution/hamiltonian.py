"""The trajectory of a linear-quadratic solution: the exact flow of its Hamiltonian system from
the nearest node (`HamiltonianFlow`).

The optimal state and costate of a linear-quadratic problem obey the linear system
d[x; lambda]/dtau = H [x; lambda] with u = -R^-1 B^T lambda (Pontryagin; Kalman 1960), so
from a node z_k = [x_k; lambda_k] at tau_k

    z(tau) = expm(H (tau - tau_k)) z_k,        tau_k <= tau <= tau_k + h,

is exact at every time, not an interpolation. The nodes lie on a uniform grid of `steps`
intervals (the Riccati sweep's, `jaxlpm.solvers.lqr`); stepping from the nearest node keeps
the exponent small (h |eig(H)| of a few units), so rounding does not grow with the horizon.
The flow works in the solver's units (tau = rate * t) and converts: state = state_unit * x,
costate = costate_unit * lambda, control = control_unit * u.
"""

from dataclasses import dataclass, field

import jax
import jax.numpy as jnp
import numpy as np

GAUSS_POINTS = 8     # Gauss-Legendre points per step for delta-v and cost integrals: exact to
#                      rounding for the smooth exponentials of steps with h |eig(H)| <~ 5


def _members(fn, obj, *args):
    """fn(obj, *args) mapped over obj's leading (batch) axes: `nodes` is (steps + 1, 2m)."""
    for _ in range(obj.nodes.ndim - 2):
        fn = jax.vmap(fn, in_axes=(0,) + (None,) * len(args))
    return fn(obj, *args)


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class FlowControl:
    """u(t) (m/s^2) of a `HamiltonianFlow` as a propagator calls it (variable "time", t in s
    since the start; clipped to [0, duration])."""

    flow: "HamiltonianFlow"
    variable: str = field(default="time", metadata=dict(static=True))

    def __call__(self, t):
        return self.flow.control(jnp.clip(t, 0.0, self.flow.duration))


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class HamiltonianFlow:
    """A linear-quadratic solution evaluated by its exact Hamiltonian flow (module docstring).

    hamiltonian   (2m, 2m) H in the solver's units (time 1/rate)
    gain          (k, m) R^-1 B^T in the solver's units: u = -gain lambda
    nodes         (steps + 1, 2m) [x; lambda] at tau_j = j h, h = rate * duration / steps
    duration      T (s)
    rate          tau = rate * t (rad/s for the HCW families: the mean motion)
    state_unit    (m,) SI state = state_unit * x (m, m/s)
    costate_unit  (m,) SI costate = costate_unit * lambda (the cost's unit per m, per m/s)
    control_unit  SI control = control_unit * u (m/s^2)
    steps         number of uniform intervals (static): the `grid`
    """

    hamiltonian: jax.Array
    gain: jax.Array
    nodes: jax.Array
    duration: jax.Array
    rate: jax.Array
    state_unit: jax.Array
    costate_unit: jax.Array
    control_unit: jax.Array
    steps: int = field(default=512, metadata=dict(static=True))

    @property
    def grid(self) -> int:
        """The number of uniform sweep intervals."""
        return self.steps

    @property
    def m(self) -> int:
        return self.nodes.shape[-1] // 2

    @property
    def times(self):
        """(steps + 1,) node times j T / steps (s)."""
        return self.duration[..., None] * jnp.arange(self.steps + 1) / self.steps

    @property
    def state_times(self):
        return self.times

    @property
    def node_states(self):
        """(steps + 1, m) SI states at `times`."""
        return self.state_unit[..., None, :] * self.nodes[..., :self.m]

    @property
    def node_costates(self):
        """(steps + 1, m) SI costates at `times`."""
        return self.costate_unit[..., None, :] * self.nodes[..., self.m:]

    @property
    def node_controls(self):
        """(steps + 1, k) SI controls at `times`."""
        u = -jnp.einsum("...ij,...kj->...ki", self.gain, self.nodes[..., self.m:])
        return self.control_unit[..., None, None] * u

    @property
    def step(self):
        """h, the sweep's interval in the solver's units."""
        return self.rate * self.duration / self.steps

    def flow(self, t):
        """[x; lambda] (solver's units) at t (s) in [0, duration], from the node before it."""
        tau, h = self.rate * t, self.step
        k = jnp.clip(jnp.floor(tau / h).astype(jnp.int32), 0, self.steps - 1)
        return jax.scipy.linalg.expm(self.hamiltonian * (tau - k * h)) @ self.nodes[k]

    def state(self, t):
        """LVLH state (m, m/s) at time t (s)."""
        return self.state_unit * self.flow(t)[:self.m]

    def control(self, t):
        """Control (m/s^2) at time t (s): u = -R^-1 B^T lambda."""
        return -self.control_unit * self.gain @ self.flow(t)[self.m:]

    def costate(self, t):
        """Costate lambda = dJ*/dx at time t (s), SI."""
        return self.costate_unit * self.flow(t)[self.m:]

    def quadrature(self):
        """(w (GAUSS_POINTS,), z (steps, GAUSS_POINTS, 2m)): Gauss-Legendre weights in tau
        (the same on every step) and [x; lambda] at the points of every step (one member)."""
        xi, wi = np.polynomial.legendre.leggauss(GAUSS_POINTS)
        h = self.step
        E = jax.vmap(jax.scipy.linalg.expm)(self.hamiltonian * (0.5 * h * (xi + 1.0))[:, None,
                                                                                      None])
        return 0.5 * h * jnp.asarray(wi), jnp.einsum("gij,kj->kgi", E, self.nodes[:-1])

    def delta_v(self):
        """int |u| dt (m/s), Gauss-Legendre on every step."""
        def one(flow):
            w, z = flow.quadrature()
            speed = jnp.linalg.norm(jnp.einsum("ij,kgj->kgi", flow.gain, z[..., flow.m:]),
                                    axis=-1)
            return flow.control_unit / flow.rate * jnp.sum(w * speed)
        return _members(one, self)

    def flight_control(self) -> FlowControl:
        return FlowControl(self)
