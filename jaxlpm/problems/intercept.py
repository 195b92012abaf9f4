"""Long-range intercept under two-body + J2 gravity (Tan, Yan, Zhou & Tang 2011): one burn,
impulsive (`ImpulsiveIntercept`) or a finite constant-thrust burn (`FiniteBurnIntercept`).

A vehicle coasts from its state at t = 0 and must be at a target position at t_f (the
velocity there is free). Frame: Earth-centred inertial, z along the Earth's rotation axis
(equatorial, the frame of `jaxlpm.dynamics.gravity`); SI units (m, m/s, s, kg, N). Both
problems write their input checks once (`jaxlpm._validation.Checked`); the solvers are
`jaxlpm.solvers.impulsive` and `jaxlpm.solvers.finite_burn`.
"""

from dataclasses import dataclass, field, replace

import jax
import jax.numpy as jnp
import numpy as np

from .._validation import Checked, Rule, array_module, check_shape, coerce_sequences, real_array
from ..constants import J2_EARTH, MU_EARTH, R_EARTH, G0
from ..orbits.epoch import canonical_epoch
from ..orbits.lambert import BRANCHES

MAX_REVOLUTIONS = 5       # Lambert revolution counts tried when `revolutions` is None


def _integer(value):
    """A Python int (or bool-free integer scalar) as a NumPy integer array; others unchanged."""
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        return np.asarray(value, dtype=np.int64)
    return value


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class ImpulsiveIntercept(Checked):
    """Intercept r_target at t_f = `duration` with one impulse of least |dv| (m/s).

    state0           [r, v] (6,) at t = 0 (m, m/s; Earth-centred inertial, equatorial)
    duration         t_f (s): the intercept time, counted from t = 0
    r_target         the position to be at at t_f (3,) (m, inertial); the velocity is free
    burn_time        when the impulse is given: a time t_b (s) with 0 < t_b < t_f, or a window
                     [t_lo, t_hi] (s), 0 < t_lo < t_hi < t_f, in which the solver chooses the
                     t_b of least |dv| (shape () or (2,): static, one compiled solver each)
    revolutions      the two-body Lambert seed's full revolutions M (an integer >= 0), or None:
                     the M in 0..max_revolutions whose seed needs the least |dv| (at each t_b)
    branch           "left" / "right" (or 0 / 1): Izzo's branch of an M >= 1 Lambert seed
                     (`jaxlpm.lambert`), or None: the one of least |dv|; moot for M = 0
    mu, j2, r_eq     gravity: mu (m^3/s^2), the J2 coefficient and the equatorial radius (m)
    max_revolutions  (static) the largest M tried when `revolutions` is None
    epoch            (static, optional) the UTC date and time of t = 0 (a datetime or an ISO
                     8601 string; `jaxlpm.orbits.epoch`): dates exported ephemerides

    Lambert seeds are prograde (angular momentum along +z). The solution is exact on the J2
    model: Newton shooting corrects the two-body seed (`jaxlpm.solvers.impulsive`).
    """

    state0: jax.Array
    duration: jax.Array
    r_target: jax.Array
    burn_time: jax.Array
    revolutions: jax.Array = None
    branch: jax.Array = None
    mu: jax.Array = MU_EARTH
    j2: jax.Array = J2_EARTH
    r_eq: jax.Array = R_EARTH
    max_revolutions: int = field(default=MAX_REVOLUTIONS, metadata=dict(static=True))
    epoch: str | None = field(default=None, metadata=dict(static=True))

    def __post_init__(self):
        coerce_sequences(self)
        object.__setattr__(self, "epoch", canonical_epoch(self.epoch))
        branch = self.branch
        if isinstance(branch, str):
            if branch not in BRANCHES:
                raise ValueError(f"branch must be 'left', 'right', 0, 1 or None, got "
                                 f"{branch!r}")
            branch = BRANCHES[branch]
        object.__setattr__(self, "branch", _integer(branch))
        object.__setattr__(self, "revolutions", _integer(self.revolutions))

    def replace(self, **kwargs) -> "ImpulsiveIntercept":
        return replace(self, **kwargs)

    @property
    def optimises_burn_time(self) -> bool:
        """True when `burn_time` is a window [t_lo, t_hi] (static: its shape)."""
        return np.shape(self.burn_time) == (2,)

    def rules(self):
        """Validity rules, written once (`jaxlpm._validation.Checked`)."""
        xp = array_module(self)
        t, tf = xp.asarray(self.burn_time), self.duration
        if self.optimises_burn_time:
            burn = (t[0] > 0.0) & (t[0] < t[1]) & (t[1] < tf)
        else:
            burn = (t > 0.0) & (t < tf)
        rules = [Rule("state0", xp.all(xp.isfinite(self.state0))
                      & (xp.linalg.norm(self.state0[:3]) > 0.0),
                      "finite with a non-zero position (m, m/s)"),
                 Rule("duration", xp.isfinite(tf) & (tf > 0.0),
                      "a positive, finite intercept time t_f in s"),
                 Rule("r_target", xp.all(xp.isfinite(self.r_target))
                      & (xp.linalg.norm(self.r_target) > 0.0),
                      "a finite, non-zero position in m"),
                 Rule("burn_time", xp.all(xp.isfinite(t)) & burn,
                      "a burn time in (0, duration) s or a window [t_lo, t_hi] with "
                      "0 < t_lo < t_hi < duration (s)"),
                 Rule("mu", xp.isfinite(self.mu) & (self.mu > 0.0),
                      "a positive, finite gravitational parameter in m^3/s^2"),
                 Rule("j2", xp.isfinite(self.j2), "finite"),
                 Rule("r_eq", xp.isfinite(self.r_eq) & (self.r_eq > 0.0),
                      "a positive equatorial radius in m")]
        if self.revolutions is not None:
            rules.append(Rule("revolutions", self.revolutions >= 0,
                              "an integer >= 0 (full Lambert revolutions) or None"))
        if self.branch is not None:
            rules.append(Rule("branch", (self.branch == 0) | (self.branch == 1),
                              "'left' (0), 'right' (1) or None"))
        return rules

    def static_rules(self) -> None:
        for name, shape in (("state0", (6,)), ("duration", ()), ("r_target", (3,)),
                            ("mu", ()), ("j2", ()), ("r_eq", ())):
            check_shape(name, getattr(self, name), shape)
        if np.shape(real_array("burn_time", self.burn_time)) not in ((), (2,)):
            raise ValueError(f"burn_time must be a time (shape ()) or a window [t_lo, t_hi] "
                             f"(shape (2,)) in s, got shape {np.shape(self.burn_time)}")
        for name in ("revolutions", "branch"):
            value = getattr(self, name)
            if value is not None and (np.shape(value) != ()
                                      or jnp.result_type(value).kind not in "iu"):
                raise ValueError(f"{name} must be an integer scalar or None, got {value!r:.60}")
        m = self.max_revolutions
        if isinstance(m, bool) or not isinstance(m, (int, np.integer)) or m < 0:
            raise ValueError(f"max_revolutions must be an integer >= 0, got {m!r}")

    def harmless(self) -> "ImpulsiveIntercept":
        """A valid intercept with the same static structure: a quarter turn at GEO radius,
        reached 8500 s late (one feasible M = 0 Lambert seed)."""
        r = 4.2e7
        burn = jnp.array([5.0e3, 1.5e4]) if self.optimises_burn_time else jnp.asarray(1.0e4)
        zero = lambda v: None if v is None else jnp.zeros((), jnp.result_type(v))
        return ImpulsiveIntercept(
            state0=jnp.array([r, 0.0, 0.0, 0.0, np.sqrt(MU_EARTH / r), 0.0]),
            duration=jnp.asarray(3.0e4), r_target=jnp.array([0.0, r, 0.0]), burn_time=burn,
            revolutions=zero(self.revolutions), branch=zero(self.branch),
            mu=jnp.asarray(MU_EARTH), j2=jnp.asarray(J2_EARTH), r_eq=jnp.asarray(R_EARTH),
            max_revolutions=self.max_revolutions, epoch=self.epoch)


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class FiniteBurnIntercept(Checked):
    """The intercept flown with a constant-thrust engine: minimise the burn duration D (s)
    over the burn start t_s and the thrust direction u_hat(t) (Tan et al. 2011, §2.5).

    intercept     the `ImpulsiveIntercept` (state0 at t = 0, t_f = its duration, r_target,
                  gravity); its impulsive solution seeds the burn (eq. 2) unless a seed is
                  given (its burn_time, revolutions and branch choose that impulse)
    thrust        F (N), constant while the engine fires
    mass          m0 (kg) at the burn start; the mass flow is F / (isp g0)
    isp           specific impulse (s)
    max_duration  D at most this (s; inf: unbounded)
    seed_time, seed_dv  the impulsive burn (t_b (s), dv (3,) m/s inertial) that eq. (2) turns
                  into the initial burn, or None (both): the solution of `intercept`

    Frame: Earth-centred inertial, equatorial; the direction u_hat is a unit vector in it.
    """

    intercept: ImpulsiveIntercept
    thrust: jax.Array
    mass: jax.Array
    isp: jax.Array
    max_duration: jax.Array = float("inf")
    seed_time: jax.Array = None
    seed_dv: jax.Array = None

    def __post_init__(self):
        coerce_sequences(self)

    def replace(self, **kwargs) -> "FiniteBurnIntercept":
        return replace(self, **kwargs)

    @property
    def mass_rate(self):
        """Propellant flow F / (isp g0) (kg/s)."""
        return self.thrust / (self.isp * G0)

    @property
    def r_target(self):
        """The intercept's target position (3,) (m, inertial)."""
        return self.intercept.r_target

    @property
    def seeded(self) -> bool:
        """True when the user gave the seed impulse (static)."""
        return self.seed_time is not None

    def rules(self):
        """Validity rules, written once (`jaxlpm._validation.Checked`); the intercept's own
        are named "intercept.<field>"."""
        xp = array_module(self)
        positive = lambda x: xp.isfinite(x) & (x > 0.0)
        rules = [r._replace(name=f"intercept.{r.name}") for r in self.intercept.rules()]
        rules += [Rule("thrust", positive(self.thrust), "positive and finite (N)"),
                  Rule("mass", positive(self.mass), "positive and finite (kg)"),
                  Rule("isp", positive(self.isp), "positive and finite (s)"),
                  Rule("max_duration", self.max_duration > 0.0, "positive (s; inf allowed)")]
        if self.seeded:
            rules += [Rule("seed_time", xp.isfinite(self.seed_time) & (self.seed_time > 0.0)
                           & (self.seed_time < self.intercept.duration),
                           "a burn time in (0, intercept.duration) s"),
                      Rule("seed_dv", xp.all(xp.isfinite(self.seed_dv))
                           & (xp.linalg.norm(self.seed_dv) > 0.0),
                           "a finite, non-zero impulse (m/s, inertial)")]
        return rules

    def static_rules(self) -> None:
        self.intercept.static_rules()
        for name in ("thrust", "mass", "isp", "max_duration"):
            check_shape(name, getattr(self, name), ())
        if (self.seed_time is None) != (self.seed_dv is None):
            raise ValueError("seed_time and seed_dv are given together or not at all (None: "
                             "the burn is seeded from the intercept's impulsive solution)")
        if self.seeded:
            check_shape("seed_time", self.seed_time, ())
            check_shape("seed_dv", self.seed_dv, (3,))

    def harmless(self) -> "FiniteBurnIntercept":
        """A valid finite burn with the same static structure (`ImpulsiveIntercept.harmless`
        flown by 200 N on 800 kg, Isp 260 s)."""
        seed = (jnp.asarray(1.0e4), jnp.array([0.0, 10.0, 0.0])) if self.seeded else (None,
                                                                                       None)
        return FiniteBurnIntercept(self.intercept.harmless(), jnp.asarray(200.0),
                                   jnp.asarray(800.0), jnp.asarray(260.0),
                                   jnp.asarray(jnp.inf), *seed)
