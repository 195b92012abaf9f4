"""A solution's spacecraft in the inertial frame: what an ephemeris (`write_oem`) writes.

Inertial frame: the one the chief's `KeplerOrbit` elements (i, raan, argp) are given in,
Earth-centred, z along the Earth's rotation axis for the J2 model; states [r, v] in m and m/s
at times t in s since the start of the transfer (the orbit's epoch).

Relative transfers (frame "LVLH"): the chief flies the solution's own model, Keplerian on
`problem.orbit` for the "linear" and "two-body" models and the HCW families (minimum time,
fuel-optimal, LQR: the chief of their linear model), and the two-body + J2 orbit osculating
`problem.orbit` at the epoch for the "j2" model (`jaxlpm.dynamics.ephemeris`). The deputy is
the chief plus the solution's LVLH state rho(t) mapped by `lvlh_to_relative_inertial`:
dr = C^T rho, dv = C^T rho_dot + w x dr, with the LVLH axes C and angular velocity w of the
chief's state and acceleration (`jaxlpm.orbits.frames`). A linear-model state is mapped as
it is (its x, y, z taken as Cartesian LVLH coordinates).
Intercepts (frame "inertial"): the spacecraft's own states; they have no chief.
"""


import jax
import jax.numpy as jnp
import numpy as np

from ..compilation import compiled
from ..dynamics import gravity_acceleration
from ..dynamics.ephemeris import j2_ephemeris, kepler_ephemeris
from ..orbits import lvlh_to_relative_inertial
from .sampling import evaluate, sample_times, single

SPACECRAFT = ("deputy", "chief")


@compiled(static_argnames=("j2_model",))
def _relative(solution, ts, j2_model: bool):
    """(chief [r, v] (k, 6), deputy [r, v] (k, 6), ok) at increasing times ts (s)."""
    problem = solution.problem
    orbit = problem.orbit
    if j2_model:
        chief, ok = j2_ephemeris(orbit, ts, problem.j2, problem.r_eq)
    else:
        chief, ok = kepler_ephemeris(orbit, ts), jnp.array(True)

    def deputy(c, rho):
        acc = (gravity_acceleration(c[:3], orbit.mu, problem.j2, problem.r_eq) if j2_model
               else None)      # Keplerian: the frame turns about h only
        dr, dv = lvlh_to_relative_inertial(c[:3], c[3:], rho, acc)
        return jnp.concatenate([c[:3] + dr, c[3:] + dv])

    return chief, jax.vmap(deputy)(chief, solution.states(ts)), ok


def inertial_states(solution, times=None, spacecraft: str = "deputy") -> np.ndarray:
    """[r, v] (len(times), 6) in m and m/s (module docstring) of `spacecraft` ("deputy" or
    "chief") at `times` (s since the start; default `sample_times`) of one solution.
    ValueError for a batch, bad times, an unknown spacecraft or the chief of an intercept;
    RuntimeError if the J2 chief's integration fails."""
    single(solution, "inertial_states")
    if spacecraft not in SPACECRAFT:
        raise ValueError(f"spacecraft must be one of {SPACECRAFT}, got {spacecraft!r}")
    t = sample_times(solution, times)
    if solution.frame == "inertial":
        if spacecraft == "chief":
            raise ValueError("an intercept (frame 'inertial') has no chief: write its "
                             "spacecraft (spacecraft='deputy')")
        return np.asarray(evaluate(solution, jnp.asarray(t))[0])
    if solution.frame != "LVLH":
        raise ValueError(f"solution.frame must be 'LVLH' or 'inertial', got {solution.frame!r}")
    ts, back = np.unique(t, return_inverse=True)
    if ts[-1] == 0.0:              # the J2 ephemeris integrates up to the last time
        ts = np.append(ts, float(np.asarray(solution.duration)))
    j2_model = getattr(solution.problem, "model", "linear") == "j2"
    chief, deputy, ok = _relative(solution, jnp.asarray(ts), j2_model)
    if not bool(ok):
        raise RuntimeError("the J2 chief's ephemeris integration failed (solve_ode: step "
                           "limit or non-finite states)")
    states = chief if spacecraft == "chief" else deputy
    return np.asarray(states)[back]
