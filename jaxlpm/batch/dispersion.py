"""Random problem families for robustness studies and Monte Carlo sweeps.

`mei2010_dispersion` draws mei2010-like rendezvous problems (Mei 2010 §4 generalised: an
eccentric chief, a chaser some kilometres away, to the origin at rest after a few revolutions)
as ONE batched `EnergyOptimalTransfer`: the same dataclass, every array leaf with a leading
batch axis n, ready for `jax.vmap(solve_one)` (or `lax.map` over chunks).
"""

import jax
import jax.numpy as jnp
import numpy as np

from ..constants import J2_EARTH, MU_EARTH, R_EARTH
from ..orbits import KeplerOrbit
from ..problems import MODELS, EnergyOptimalTransfer

# The distribution (SI units, angles in rad). Change it only with a new name: results files
# quote these numbers.
PERIGEE_ALTITUDE = 600e3            # m, chief perigee altitude above R_EARTH (held fixed)
E_RANGE = (0.0, 0.7)                # chief eccentricity, uniform
INCLINATION = np.deg2rad(30.0)      # rad, fixed (mei2010's chief; matters only under J2)
RAAN = np.deg2rad(30.0)             # rad, fixed (mei2010's chief; matters only under J2)
REVOLUTIONS_RANGE = (1.0, 5.0)      # transfer duration in chief periods, uniform
POSITION_HALF_WIDTH = 25e3          # m: chaser LVLH position uniform in a 50 km cube
VELOCITY_HALF_WIDTH = 10.0          # m/s: chaser LVLH velocity uniform in +-10 m/s per axis


def mei2010_dispersion(key, n: int, model: str = "two-body", thrust_axes=(True, True, True),
                       j2=J2_EARTH, r_eq=R_EARTH, mu=MU_EARTH) -> EnergyOptimalTransfer:
    """n random mei2010-like rendezvous problems as one batched `EnergyOptimalTransfer`.

    Distribution (independent draws, `jax.random`, float64; all leaves have shape (n, ...)):
      chief perigee radius  r_p = R_EARTH + 600 km (held fixed, so no perigee underground)
      eccentricity          e    ~ U[0, 0.7]              ->  a = r_p / (1 - e)   (m)
                                                              (a from 6978 km to 23260 km)
      inclination           i    = 30 deg (fixed)          \\ as mei2010's chief; they matter
      RAAN                  raan = 30 deg (fixed)           } only for model "j2" (J2 acts on
      argument of perigee   argp ~ U[0, 2 pi)              / the chief's orientation)
      initial true anomaly  f0   ~ U[0, 2 pi)
      duration              revolutions ~ U[1, 5], duration = revolutions * 2 pi / n_chief (s)
      chaser initial state  x0 (LVLH: x radial out, y along-track, z orbit normal)
                            position ~ U[-25, 25] km per axis (a 50 km cube about the chief),
                            velocity ~ U[-10, 10] m/s per axis
      final state           xf = 0 (rendezvous with the chief, at rest in LVLH)
      model, thrust_axes    as given (static); j2, r_eq, mu: as given, broadcast to (n,)

    The draws use one split of `key` per quantity (order: e, argp, f0, revolutions, position,
    velocity), so a given (key, n) always gives the same problems; with JAX's default
    partitionable Threefry (jax_threefry_partitionable=True) the first k problems of a draw of
    n are also the draw of k. Returns the batched problem; `dispersion_parameters` tabulates
    it.
    """
    if model not in MODELS:
        raise ValueError(f"model must be one of {MODELS}, got {model!r}")
    n = int(n)
    if n < 1:
        raise ValueError(f"n must be a positive number of problems, got {n}")
    if not jax.config.jax_enable_x64:
        raise ValueError("jaxlpm needs float64: call jax.config.update('jax_enable_x64', True)")
    k_e, k_w, k_f, k_rev, k_r, k_v = jax.random.split(key, 6)
    f64 = jnp.float64

    def uniform(k, lo, hi, shape=(n,)):
        return jax.random.uniform(k, shape, f64, lo, hi)

    e = uniform(k_e, *E_RANGE)
    argp = uniform(k_w, 0.0, 2.0 * jnp.pi)
    f0 = uniform(k_f, 0.0, 2.0 * jnp.pi)
    revolutions = uniform(k_rev, *REVOLUTIONS_RANGE)
    pos = uniform(k_r, -POSITION_HALF_WIDTH, POSITION_HALF_WIDTH, (n, 3))
    vel = uniform(k_v, -VELOCITY_HALF_WIDTH, VELOCITY_HALF_WIDTH, (n, 3))

    full = lambda v: jnp.full((n,), v, f64)                              # noqa: E731
    r_p = R_EARTH + PERIGEE_ALTITUDE
    orbit = KeplerOrbit(a=r_p / (1.0 - e), e=e, i=full(INCLINATION), raan=full(RAAN),
                        argp=argp, f0=f0, mu=full(mu))
    return EnergyOptimalTransfer(
        orbit=orbit, x0=jnp.concatenate([pos, vel], axis=1), xf=jnp.zeros((n, 6), f64),
        duration=revolutions * orbit.period, thrust_axes=tuple(bool(a) for a in thrust_axes),
        model=model, j2=full(j2), r_eq=full(r_eq))


def dispersion_parameters(problems: EnergyOptimalTransfer) -> dict:
    """The sampled parameters of a batched transfer as a dict of NumPy arrays (SI, rad):
    a, e, i, raan, argp, f0, revolutions, duration, x0 (n, 6), xf (n, 6)."""
    o = problems.orbit
    out = {name: np.asarray(getattr(o, name)) for name in ("a", "e", "i", "raan", "argp", "f0")}
    out["duration"] = np.asarray(problems.duration)
    out["revolutions"] = np.asarray(problems.duration / o.period)
    out["x0"] = np.asarray(problems.x0)
    out["xf"] = np.asarray(problems.xf)
    return out
