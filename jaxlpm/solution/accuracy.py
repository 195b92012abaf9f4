"""How accurate a solution is between its nodes, in SI, and the status that says so.

Every family estimates, inside its compiled solver, how far its states are from the flow of
its own control (the collocated ones by `jaxlpm.nlp.accuracy`, the GPOPS-II estimate; the
LQR sweep and the intercepts in their solvers' modules) and reports it in `Solution.stats`
(`accuracy_stats`):

  error_position  (m)    the largest distance between the state polynomial and the flight of
                         its own control on the check mesh (`jaxlpm.nlp.accuracy.check_flight`),
                         over the check rows: an estimate of `verify.fly`'s plan_error, and so
                         a bound on the flown terminal miss (the polynomial ends on the target)
  error_velocity  (m/s)  the same for the velocity
  relative_error  (-)    the largest relative error of a segment (nondimensional states,
                         Patterson, Hager & Rao 2015 eq. 38)
  segment_error   (K,)   each segment's relative error (one for a single grid)
  path_violation  the largest violation of a path constraint between the nodes, in the
                  family's unit (0: none); fuel-optimal: the delta-v beyond the thrust
                  bound, int max(|u| - u_max, 0) dt (m/s), and the same for an
                  energy-optimal transfer's `ThrustLimit`

With safety constraints (`jaxlpm.problems.safety`) an energy-optimal solution also reports,
from the same dense check, `constraint_violation` (each constraint's largest violation in its
SI unit), `violation_position` (m: keep-out, approach cone, passive safety) and
`violation_velocity` (m/s: speed limits), judged against the position and velocity
tolerances.

`Tolerance` is what `jaxlpm.solve` accepts: a converged solution whose estimate exceeds it is
`Status.INACCURATE` (`judge`). The default (0.1 m, 1e-4 m/s) is a tenth of the goal that a
default solve's flown terminal miss stay within 1 m and 1 mm/s: the flown miss was at most
1.7x the estimate over e in [0, 0.7], 1-5 revolutions and grids from lgl(17) to 16 x 16 LGR
segments (tests/test_accuracy.py asserts 3x; experiments/robustness_newton.py --refine
flies every member of the robustness dispersion).
"""

from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from .._validation import is_concrete
from ..status import Status


@dataclass(frozen=True)
class Tolerance:
    """The accuracy a solution must reach to be SUCCESS (SI): the largest position error
    (m) and velocity error (m/s) of the state polynomial against the flow of its own control
    between the nodes (`stats["error_position"]`, `stats["error_velocity"]`), and the largest
    path-constraint violation between the nodes (`stats["path_violation"]`, in the family's
    unit: for the fuel-optimal thrust bound the delta-v beyond it, m/s, so the default is
    the velocity tolerance; the same for an energy-optimal `ThrustLimit`; ignored by
    families without path constraints). Safety constraints in m (keep-out, approach cone,
    passive safety) are judged against `position`, speed limits against `velocity`."""

    position: float = 0.1
    velocity: float = 1e-4
    path: float = 1e-4

    def __post_init__(self):
        for name in ("position", "velocity", "path"):
            value = getattr(self, name)
            if isinstance(value, bool) or not np.isfinite(value) or value <= 0.0:
                raise ValueError(f"Tolerance.{name} must be a positive finite number, got "
                                 f"{value!r}")


DEFAULT_TOLERANCE = Tolerance()
"""The tolerance `solve` uses when given none: `Tolerance()`, the defaults above."""


def accuracy_stats(errors_si, relative, path=None):
    """The stats of the module docstring from the SI errors (..., 6) at the check rows
    (position m then velocity m/s), the segments' relative errors (K,) and the path values g
    at the check points (any shape; None: no path constraints)."""
    flat = errors_si.reshape(-1, errors_si.shape[-1])
    violation = (jnp.zeros((), flat.dtype) if path is None or path.size == 0
                 else jnp.maximum(jnp.max(path), 0.0))
    return dict(error_position=jnp.max(jnp.linalg.norm(flat[:, :3], axis=-1)),
                error_velocity=jnp.max(jnp.linalg.norm(flat[:, 3:6], axis=-1)),
                relative_error=jnp.max(relative), segment_error=relative,
                path_violation=violation)


def inaccurate(stats, tolerance: Tolerance):
    """True where the estimate in `stats` exceeds `tolerance` (or is not finite)."""
    ok = ((stats["error_position"] <= tolerance.position)
          & (stats["error_velocity"] <= tolerance.velocity)
          & (stats["path_violation"] <= tolerance.path))
    if "violation_position" in stats:          # safety constraints (module docstring)
        ok = (ok & (stats["violation_position"] <= tolerance.position)
              & (stats["violation_velocity"] <= tolerance.velocity))
    return ~ok


def refinement_error(stats, tolerance: Tolerance):
    """(K,) the error by which mesh refinement shares out a rung's segments
    (`jaxlpm.solvers.refine.split_breaks`, pieces in proportion to its fourth root): each
    segment's relative error (`segment_error`), raised where the dense check of the safety
    constraints in that segment (`segment_violation`: m, m/s, delta-v beyond a thrust bound)
    exceeds the tolerance by kappa > 1 to e_max kappa^4 (e_max the largest segment error), so
    that such a segment gets kappa times the pieces of the least accurate one: a path that
    rides a constraint leaves it between the nodes where its nodes are sparse, whatever the
    dynamics' error there."""
    error = stats["segment_error"]
    if "segment_violation" not in stats:
        return error
    limits = jnp.asarray([tolerance.position, tolerance.velocity, tolerance.path], error.dtype)
    kappa = jnp.max(stats["segment_violation"] / limits, axis=-1)
    e_max = jnp.maximum(jnp.max(error, axis=-1, keepdims=True), jnp.finfo(error.dtype).tiny)
    return jnp.where(kappa > 1.0, jnp.maximum(error, e_max * kappa ** 4), error)


def judge(solution, tolerance: Tolerance):
    """The solution with SUCCESS turned into INACCURATE where its estimate exceeds
    `tolerance` (works under jit and vmap; a family without the estimate is returned as it
    is)."""
    if "error_position" not in solution.stats:
        return solution
    status = solution.status
    stats = {k: v for k, v in solution.stats.items() if k in _JUDGED}
    xp = np if is_concrete(status, stats) else jnp
    if xp is np:     # on the host: jnp on concrete arrays compiles a program per operation
        status, stats = np.asarray(status), jax.tree_util.tree_map(np.asarray, stats)
    status = xp.where((status == Status.SUCCESS) & inaccurate(stats, tolerance),
                      Status.INACCURATE, status).astype(xp.int32)
    return solution.replace(status=jnp.asarray(status))


_JUDGED = ("error_position", "error_velocity", "path_violation", "violation_position",
           "violation_velocity")


@dataclass(frozen=True)
class Judge:
    """`judge` bound to a tolerance: what the families' `solve` and mesh refinement take
    (called on a solution it sets INACCURATE; `refinement_error` says where to split)."""

    tolerance: Tolerance = DEFAULT_TOLERANCE

    def __call__(self, solution):
        return judge(solution, self.tolerance)

    def refinement_error(self, solution):
        return refinement_error(solution.stats, self.tolerance)
