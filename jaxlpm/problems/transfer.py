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

import functools
from dataclasses import dataclass, field, replace

import jax
import jax.numpy as jnp
import numpy as np

from .._validation import check_shape, coerce_sequences, is_concrete
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

    def __post_init__(self):
        coerce_sequences(self)
        axes = self.thrust_axes
        if (isinstance(axes, (tuple, list, np.ndarray)) and np.ndim(axes) == 1
                and all(isinstance(a, (bool, np.bool_)) for a in axes)):
            # static, so compared by jit: Python bools (an array would not compare simply)
            object.__setattr__(self, "thrust_axes", tuple(bool(a) for a in axes))

    @classmethod
    def from_revolutions(cls, orbit, x0, xf, revolutions, thrust_axes=(True, True, True),
                         model="linear"):
        """Transfer lasting `revolutions` chief orbital periods (duration = revolutions * 2 pi/n)."""
        if is_concrete(orbit):
            orbit.validate()           # the period needs a > 0 and mu > 0
        return cls(orbit, x0, xf, revolutions * orbit.period, thrust_axes, model)

    def replace(self, **kwargs) -> "EnergyOptimalTransfer":
        return replace(self, **kwargs)

    def checks(self):
        """The problem's validity rules, written once: (field, in-graph flag, what is allowed).
        Concrete input raises on the first failure (`validate`); traced input gets status
        INVALID_INPUT (`validity`). The nonlinear models fly the chief on its orbit, so they
        need its perigee above the surface (r_p = a (1 - e) > r_eq); the linear model is a
        local expansion that does not care."""
        o = self.orbit
        rules = [*o.checks(),
                 ("x0", jnp.all(jnp.isfinite(self.x0)), "finite (m, m/s)"),
                 ("xf", jnp.all(jnp.isfinite(self.xf)), "finite (m, m/s)"),
                 ("duration", jnp.isfinite(self.duration) & (self.duration > 0.0),
                  "a positive, finite duration in s"),
                 ("j2", jnp.isfinite(self.j2), "finite"),
                 ("r_eq", jnp.isfinite(self.r_eq) & (self.r_eq > 0.0),
                  "a positive equatorial radius in m")]
        if self.model != "linear":
            rules.append(("orbit", perigee_above_surface(o.a, o.e, self.r_eq),
                          f"an orbit whose perigee a (1 - e) is above r_eq on the "
                          f"{self.model!r} model"))
        return rules

    def validate_static(self) -> None:
        """Raise ValueError for what is known at trace time too: model, thrust axes, the
        fields' types and shapes (x0, xf (6,); every other field a scalar)."""
        if self.model not in MODELS:
            raise ValueError(f"model must be one of {MODELS}, got {self.model!r}")
        axes = self.thrust_axes
        if len(axes) != 3 or not all(isinstance(a, (bool, np.bool_)) for a in axes):
            raise ValueError(f"thrust_axes must be three booleans (x, y, z), got {axes!r}")
        for name, shape in (("x0", (6,)), ("xf", (6,)), ("duration", ()), ("j2", ()),
                            ("r_eq", ())):
            check_shape(name, getattr(self, name), shape)
        self.orbit.validate_static()

    def validate(self) -> None:
        """Raise ValueError naming the problem and what is allowed (concrete inputs only)."""
        self.validate_static()
        for name, ok, allowed in self.checks():
            if not bool(ok):
                owner, _, attr = name.rpartition(".")
                value = getattr(self.orbit if owner else self, attr)
                raise ValueError(f"{name} must be {allowed}, got {value}")

    def validity(self):
        """In-graph validity flag for traced inputs (the checks of `validate`)."""
        return functools.reduce(jnp.logical_and, [ok for _, ok, _ in self.checks()])

    def sanitized(self, valid):
        """A copy whose leaves are replaced by a harmless problem where `valid` is False, so an
        invalid member of a batch computes finite numbers (then zeroed) instead of NaNs."""
        return self.replace(
            orbit=self.orbit.sanitized(valid),
            x0=jnp.where(valid, self.x0, jnp.array([1.0, 0, 0, 0, 0, 0])),
            xf=jnp.where(valid, self.xf, 0.0),
            duration=jnp.where(valid, self.duration, 1000.0),
            j2=jnp.where(valid, self.j2, 0.0),
            r_eq=jnp.where(valid, self.r_eq, R_EARTH),
        )


def perigee_above_surface(a, e, r_eq=R_EARTH):
    """True where the chief's perigee radius a (1 - e) exceeds the body's radius r_eq (m)."""
    return a * (1.0 - e) > r_eq


def check_problem(problem: EnergyOptimalTransfer) -> None:
    """Validate at the Python boundary: everything when the inputs are concrete, the static
    part (types, shapes, model) when they are traced."""
    if not isinstance(problem, EnergyOptimalTransfer):
        raise ValueError(f"problem must be an EnergyOptimalTransfer, got "
                         f"{type(problem).__name__}")
    if is_concrete(problem):
        problem.validate()
    else:
        problem.validate_static()
