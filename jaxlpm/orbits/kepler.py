"""Keplerian orbits: the chief's reference orbit, time <-> true anomaly, elements <-> state.

Angles in radians, lengths in m, times in s, inertial frame = the Earth-centred inertial frame
in which the elements are defined. True anomaly and time are continuous: a true anomaly of
6*pi is three revolutions after f = 0, never wrapped.
"""

from dataclasses import dataclass, field, replace

import jax
import jax.numpy as jnp

from .._validation import Checked, Rule, array_module, check_scalars
from ..constants import MU_EARTH
from ..implicit import root
from .epoch import canonical_epoch

ANGLES = ("i", "raan", "argp", "f0")


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class KeplerOrbit(Checked):
    """A Keplerian orbit (the chief's, or an intercept's target): semi-major axis a (m),
    eccentricity e in [0, 1), inclination i, right ascension of the ascending node raan and
    argument of perigee argp (rad, in the central body's inertial equatorial frame: ECI for
    the Earth), the true anomaly f0 (rad) at t = 0, and the gravitational parameter mu
    (m^3/s^2, the Earth's by default). epoch: optionally, the UTC date and time of t = 0
    (a datetime or an ISO 8601 string, held as its canonical string: `jaxlpm.orbits.epoch`);
    no computation uses it, exported ephemerides are dated by it (`jaxlpm.io.write_oem`).

    Every field but the epoch is an array leaf, so sweeps over e or a reuse one compiled
    function; the epoch is static (one per batch).
    """

    a: jax.Array
    e: jax.Array
    i: jax.Array = 0.0
    raan: jax.Array = 0.0
    argp: jax.Array = 0.0
    f0: jax.Array = 0.0
    mu: jax.Array = field(default=MU_EARTH)
    epoch: str | None = field(default=None, metadata=dict(static=True))

    def __post_init__(self):
        object.__setattr__(self, "epoch", canonical_epoch(self.epoch))

    def replace(self, **kwargs) -> "KeplerOrbit":
        return replace(self, **kwargs)

    def rules(self):
        """The orbit's validity rules, written once (`jaxlpm._validation.Checked`): `validate`
        raises on the first that fails (concrete input), `validity` is their conjunction
        (traced input: status INVALID_INPUT)."""
        xp = array_module(self)
        finite = {n: xp.isfinite(getattr(self, n)) for n in ANGLES}
        return [Rule("orbit.a", xp.isfinite(self.a) & (self.a > 0.0),
                     "a positive, finite semi-major axis in m"),
                Rule("orbit.e", xp.isfinite(self.e) & (self.e >= 0.0) & (self.e < 1.0),
                     "an eccentricity in [0, 1) (elliptic chief)"),
                Rule("orbit.mu", xp.isfinite(self.mu) & (self.mu > 0.0),
                     "a positive, finite gravitational parameter in m^3/s^2"),
                *[Rule(f"orbit.{n}", ok, "a finite angle in rad") for n, ok in finite.items()]]

    def static_rules(self) -> None:
        """Raise ValueError unless every field is a real scalar (known at trace time too)."""
        check_scalars("orbit.", self, ("a", "e", *ANGLES, "mu"))

    def harmless(self) -> "KeplerOrbit":
        """A valid circular orbit (stands in for an invalid member of a batch)."""
        return KeplerOrbit(a=7.0e6, e=0.0, i=0.0, raan=0.0, argp=0.0, f0=0.0, mu=MU_EARTH,
                           epoch=self.epoch)

    @property
    def p(self):
        """Semi-latus rectum a(1 - e^2), m."""
        return self.a * (1.0 - self.e**2)

    @property
    def mean_motion(self):
        """n = sqrt(mu / a^3), rad/s."""
        return jnp.sqrt(self.mu / self.a**3)

    @property
    def period(self):
        """Orbital period 2 pi / n, s."""
        return 2.0 * jnp.pi / self.mean_motion

    @property
    def k2(self):
        """k^2 = sqrt(mu / p^3) = mu^2 / h^3 (1/s): f_dot = k^2 (1 + e cos f)^2 (Yamanaka-Ankersen)."""
        return jnp.sqrt(self.mu / self.p**3)


def _beta(e):
    return e / (1.0 + jnp.sqrt(1.0 - e**2))


def eccentric_from_true(f, e):
    """Eccentric anomaly E(f), continuous in f: E = f - 2 atan(beta sin f / (1 + beta cos f)),
    beta = e / (1 + sqrt(1 - e^2)) (the half-angle relation tan(E/2) = sqrt((1-e)/(1+e)) tan(f/2)
    written without branch cuts)."""
    b = _beta(e)
    return f - 2.0 * jnp.arctan2(b * jnp.sin(f), 1.0 + b * jnp.cos(f))


def true_from_eccentric(E, e):
    """True anomaly f(E), continuous: f = E + 2 atan(beta sin E / (1 - beta cos E))."""
    b = _beta(e)
    return E + 2.0 * jnp.arctan2(b * jnp.sin(E), 1.0 - b * jnp.cos(E))


def mean_from_true(f, e):
    """Mean anomaly M = E - e sin E, continuous in f."""
    E = eccentric_from_true(f, e)
    return E - e * jnp.sin(E)


def _kepler_residual(E, M, e):
    return E - e * jnp.sin(E) - M


@root(_kepler_residual)
def _solve_kepler(E_init, M, e):
    del E_init
    two_pi = 2.0 * jnp.pi
    revs = jnp.round(M / two_pi)
    Mr = M - two_pi * revs                      # in [-pi, pi]
    E = Mr + 0.85 * e * jnp.sign(jnp.sin(Mr))   # Danby's starter: converges for all e < 1

    def newton(_, E):
        return E - (E - e * jnp.sin(E) - Mr) / (1.0 - e * jnp.cos(E))

    E = jax.lax.fori_loop(0, 30, newton, E)
    return E + two_pi * revs


def eccentric_from_mean(M, e):
    """Solve Kepler's equation M = E - e sin E for E (continuous in M, any number of revolutions).

    Newton's method from Danby's starter, 30 fixed iterations (quadratic convergence reaches
    machine precision in < 10 for e < 0.99); differentiated implicitly, not by unrolling.
    """
    return _solve_kepler(M, M, e)


def time_from_true_anomaly(orbit: KeplerOrbit, f):
    """Time (s) since the orbit's epoch (where f = f0) at true anomaly f; continuous in f."""
    return (mean_from_true(f, orbit.e) - mean_from_true(orbit.f0, orbit.e)) / orbit.mean_motion


def true_anomaly_from_time(orbit: KeplerOrbit, t):
    """True anomaly f (rad) at time t (s) after the epoch; continuous in t (never wrapped)."""
    M = mean_from_true(orbit.f0, orbit.e) + orbit.mean_motion * t
    return true_from_eccentric(eccentric_from_mean(M, orbit.e), orbit.e)


def _rotation(raan, i, argp):
    """Perifocal -> inertial rotation R3(-raan) R1(-i) R3(-argp); columns P, Q, W."""
    cO, sO, ci, si, cw, sw = (jnp.cos(raan), jnp.sin(raan), jnp.cos(i), jnp.sin(i),
                              jnp.cos(argp), jnp.sin(argp))
    P = jnp.stack([cO * cw - sO * sw * ci, sO * cw + cO * sw * ci, sw * si])
    Q = jnp.stack([-cO * sw - sO * cw * ci, -sO * sw + cO * cw * ci, cw * si])
    W = jnp.stack([sO * si, -cO * si, ci])
    return jnp.stack([P, Q, W], axis=1)


def elements_to_state(orbit: KeplerOrbit, f=None):
    """Inertial position (m) and velocity (m/s) at true anomaly f (default: the epoch's f0).

    r = p/(1 + e cos f) (cos f P + sin f Q), v = sqrt(mu/p) (-sin f P + (e + cos f) Q).
    """
    f = orbit.f0 if f is None else f
    p = orbit.p
    R = _rotation(orbit.raan, orbit.i, orbit.argp)
    r_pf = p / (1.0 + orbit.e * jnp.cos(f)) * jnp.stack([jnp.cos(f), jnp.sin(f), 0.0 * f])
    v_pf = jnp.sqrt(orbit.mu / p) * jnp.stack([-jnp.sin(f), orbit.e + jnp.cos(f), 0.0 * f])
    return R @ r_pf, R @ v_pf


def state_to_elements(r, v, mu=MU_EARTH) -> KeplerOrbit:
    """Classical elements of an inertial state (elliptic orbits), epoch at this state.

    Conventions where elements are undefined: equatorial orbits (i = 0 or pi) take raan = 0 and
    measure argp from the x axis; circular orbits take argp = 0 and measure f from the node
    (or from the x axis when also equatorial). Angles in [0, 2 pi) except i in [0, pi].
    """
    rn = jnp.linalg.norm(r)
    h = jnp.cross(r, v)
    hn = jnp.linalg.norm(h)
    evec = jnp.cross(v, h) / mu - r / rn
    e = jnp.linalg.norm(evec)
    a = 1.0 / (2.0 / rn - jnp.dot(v, v) / mu)
    i = jnp.arccos(jnp.clip(h[2] / hn, -1.0, 1.0))
    node = jnp.array([-h[1], h[0], 0.0])
    nn = jnp.linalg.norm(node)
    tiny = 1e-12
    equatorial = nn < tiny * hn
    circular = e < 1e-12
    node_dir = jnp.where(equatorial, jnp.array([1.0, 0.0, 0.0]), node / jnp.where(equatorial, 1.0, nn))
    raan = jnp.where(equatorial, 0.0, jnp.arctan2(node[1], node[0]))
    w_hat = h / hn
    ref = jnp.where(circular, node_dir, evec / jnp.where(circular, 1.0, e))

    def angle(from_dir, to_vec):
        return jnp.arctan2(jnp.dot(jnp.cross(from_dir, to_vec), w_hat), jnp.dot(from_dir, to_vec))

    argp = jnp.where(circular, 0.0, angle(node_dir, evec))
    f = angle(ref, r)
    return KeplerOrbit(a=a, e=e, i=i, raan=_wrap_2pi(raan), argp=_wrap_2pi(argp),
                       f0=_wrap_2pi(f), mu=mu)


def _wrap_2pi(x):
    """x mod 2 pi in [0, 2 pi): mod of a tiny negative angle rounds to exactly 2 pi; map it to 0."""
    two_pi = 2.0 * jnp.pi
    y = jnp.mod(x, two_pi)
    return jnp.where(y >= two_pi, 0.0, y)
