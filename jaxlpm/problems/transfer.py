"""Energy-optimal relative transfer on the linearised elliptic model (Mei 2010, eq. 5).

minimise  J = 1/2 int_0^T |u|^2 dt      (m^2/s^3)
subject to the linearised relative dynamics about a Keplerian chief (Tschauner-Hempel),
           x(0) = x0, x(T) = xf          (LVLH: x radial out, y along-track, z normal; m, m/s)

The transfer starts at the orbit's epoch (chief true anomaly f0) and lasts `duration` seconds.
Every numeric field is an array leaf (sweeps over e, states or duration reuse one compiled
function); `thrust_axes` is static: which LVLH thrust channels exist (a removed channel can
make the problem uncontrollable, which the laws report as status SINGULAR).
"""

from dataclasses import dataclass, field, replace

import jax
import jax.numpy as jnp
import numpy as np

from .._validation import check_finite, check_shape, is_concrete
from ..orbits import KeplerOrbit


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class EnergyOptimalTransfer:
    orbit: KeplerOrbit
    x0: jax.Array
    xf: jax.Array
    duration: jax.Array
    thrust_axes: tuple = field(default=(True, True, True), metadata=dict(static=True))

    @classmethod
    def from_revolutions(cls, orbit, x0, xf, revolutions, thrust_axes=(True, True, True)):
        """Transfer lasting `revolutions` chief orbital periods (duration = revolutions * 2 pi/n)."""
        return cls(orbit, x0, xf, revolutions * orbit.period, thrust_axes)

    def replace(self, **kwargs) -> "EnergyOptimalTransfer":
        return replace(self, **kwargs)

    def validate(self) -> None:
        """Raise ValueError naming the problem and what is allowed (concrete inputs only)."""
        check_shape("x0", self.x0, (6,))
        check_shape("xf", self.xf, (6,))
        for name in ("a", "e", "i", "raan", "argp", "f0", "mu"):
            check_shape(f"orbit.{name}", getattr(self.orbit, name), ())
        check_shape("duration", self.duration, ())
        check_finite("x0", self.x0)
        check_finite("xf", self.xf)
        e = float(check_finite("orbit.e", self.orbit.e))
        if not 0.0 <= e < 1.0:
            raise ValueError(f"orbit.e must be in [0, 1) (elliptic chief), got {e}")
        if not float(check_finite("orbit.a", self.orbit.a)) > 0.0:
            raise ValueError(f"orbit.a must be a positive semi-major axis in m, got {self.orbit.a}")
        if not float(check_finite("duration", self.duration)) > 0.0:
            raise ValueError(f"duration must be positive (s), got {self.duration}")
        axes = self.thrust_axes
        if len(axes) != 3 or not all(isinstance(a, (bool, np.bool_)) for a in axes):
            raise ValueError(f"thrust_axes must be three booleans (x, y, z), got {axes!r}")

    def validity(self):
        """In-graph validity flag for traced inputs (the same checks as `validate`)."""
        o = self.orbit
        finite = jnp.all(jnp.isfinite(self.x0)) & jnp.all(jnp.isfinite(self.xf))
        finite &= jnp.isfinite(o.e) & jnp.isfinite(o.a) & jnp.isfinite(self.duration)
        return finite & (o.e >= 0.0) & (o.e < 1.0) & (o.a > 0.0) & (self.duration > 0.0)

    def sanitized(self, valid):
        """A copy whose leaves are replaced by a harmless problem where `valid` is False, so an
        invalid member of a batch computes finite numbers (then zeroed) instead of NaNs."""
        o = self.orbit
        safe_orbit = o.replace(e=jnp.where(valid, o.e, 0.0), a=jnp.where(valid, o.a, 7.0e6))
        return self.replace(
            orbit=safe_orbit,
            x0=jnp.where(valid, self.x0, jnp.array([1.0, 0, 0, 0, 0, 0])),
            xf=jnp.where(valid, self.xf, 0.0),
            duration=jnp.where(valid, self.duration, 1000.0),
        )


def check_problem(problem: EnergyOptimalTransfer) -> None:
    """Validate at the Python boundary when the inputs are concrete."""
    if is_concrete(problem):
        problem.validate()
