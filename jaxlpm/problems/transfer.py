"""Energy-optimal relative transfer (Mei 2010, eq. 5) on a choice of dynamics model.

minimise  J = 1/2 int_0^T |u|^2 dt      (m^2/s^3)
subject to the relative dynamics of `model`,
           x(0) = x0, x(T) = xf          (LVLH: x radial out, y along-track, z normal; m, m/s)

models: "linear"   linearised about a Keplerian chief (Tschauner-Hempel; the LQ laws' model)
        "two-body" exact nonlinear relative motion, chief and deputy under two-body gravity
        "j2"       exact nonlinear relative motion with J2 acting on both spacecraft; the chief
                   starts on the state that `orbit` gives at its epoch (osculating elements)

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
from ..constants import J2_EARTH, R_EARTH
from ..orbits import KeplerOrbit

MODELS = ("linear", "two-body", "j2")


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class EnergyOptimalTransfer:
    orbit: KeplerOrbit
    x0: jax.Array
    xf: jax.Array
    duration: jax.Array
    thrust_axes: tuple = field(default=(True, True, True), metadata=dict(static=True))
    model: str = field(default="linear", metadata=dict(static=True))
    j2: jax.Array = J2_EARTH
    r_eq: jax.Array = R_EARTH

    @classmethod
    def from_revolutions(cls, orbit, x0, xf, revolutions, thrust_axes=(True, True, True),
                         model="linear"):
        """Transfer lasting `revolutions` chief orbital periods (duration = revolutions * 2 pi/n)."""
        return cls(orbit, x0, xf, revolutions * orbit.period, thrust_axes, model)

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
        if self.model not in MODELS:
            raise ValueError(f"model must be one of {MODELS}, got {self.model!r}")
        check_shape("j2", self.j2, ())
        check_shape("r_eq", self.r_eq, ())
        check_finite("j2", self.j2)
        if not float(check_finite("r_eq", self.r_eq)) > 0.0:
            raise ValueError(f"r_eq must be a positive equatorial radius in m, got {self.r_eq}")
        axes = self.thrust_axes
        if len(axes) != 3 or not all(isinstance(a, (bool, np.bool_)) for a in axes):
            raise ValueError(f"thrust_axes must be three booleans (x, y, z), got {axes!r}")

    def validity(self):
        """In-graph validity flag for traced inputs (the same checks as `validate`)."""
        o = self.orbit
        finite = jnp.all(jnp.isfinite(self.x0)) & jnp.all(jnp.isfinite(self.xf))
        finite &= jnp.isfinite(o.e) & jnp.isfinite(o.a) & jnp.isfinite(self.duration)
        finite &= jnp.isfinite(self.j2) & jnp.isfinite(self.r_eq)
        return (finite & (o.e >= 0.0) & (o.e < 1.0) & (o.a > 0.0) & (self.duration > 0.0)
                & (self.r_eq > 0.0))

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
