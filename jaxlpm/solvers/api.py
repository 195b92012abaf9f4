"""`solve(problem, grid=None, *, method=None, options=None, throw=True)`: the one entry point.

The problem's type picks the family (`FAMILIES`); each family checks its input and runs its
compiled solver; every family returns a `Solution`.

| problem                 | methods (default first)                 | default grid          |
|-------------------------|-----------------------------------------|-----------------------|
| `EnergyOptimalTransfer` | "kkt", "stm" (linear model, LGL grids), | lgl(65)               |
|                         | "newton" (any model and grid)           |                       |
| `MinimumTimeTransfer`   | "augmented-lagrangian" (HCW),           | lg(32) (HCW),         |
|                         | "condensed" (any e and model)           | 16 LGR segments of 8  |
| `FuelOptimalTransfer`   | "homotopy" (any e and model; LGR, LG),  | 24 LGR segments of 8  |
|                         | "augmented-lagrangian" (safety          |                       |
|                         | constraints; LGL segments; on request)  |                       |
| `LQRTransfer`           | "riccati" (exact Riccati sweep)         | 512 steps (an int)    |
| `ImpulsiveIntercept`    | "shooting" (Lambert + J2 Newton)        | none (grid=None)      |
| `FiniteBurnIntercept`   | "augmented-lagrangian" (LGL burn arc)   | lgl(5), raised to 9,  |
|                         |                                         | 13, 21 points         |

Grids count their points: `lgl(65)` has 65 LGL points (Mei 2010's degree N = 64).
"""

import numpy as np

from .._validation import is_concrete, require_x64
from ..solution import DEFAULT_TOLERANCE, Judge, Solution, SolveError, Tolerance
from ..status import Status
from . import energy_optimal, fuel_optimal, min_time
from . import finite_burn, impulsive, lqr

FAMILIES = {f.problem: f for f in (energy_optimal.FAMILY, min_time.FAMILY, fuel_optimal.FAMILY,
                                   lqr.FAMILY, impulsive.FAMILY, finite_burn.FAMILY)}


def solve(problem, grid=None, *, method=None, options=None, tolerance=None,
          throw=True) -> Solution:
    """Solve a transfer problem of any family; returns a `Solution` (SI; module table).

    grid: a `Grid` (lgl(n), lg(n), lgr(n): n points), a `Mesh` (lgr_mesh(k, n), lg_mesh(k, n),
    lgl_mesh(k, n)), or, for fuel-optimal transfers and minimum-time method "condensed", a
    `SegmentedMesh` (segmented_lgr(breaks, n), segmented_lg(breaks, n), segmented_lgl(breaks,
    n); breaks as fractions of the transfer's anomaly span; LGL segments for the fuel-optimal
    augmented Lagrangian only); None: the family's default (concrete input: mesh refinement
    on the family's ladder); for energy-optimal, fuel-optimal and minimum-time transfers a
    `MeshLadder`: refinement on that ladder (`MeshLadder(rungs, scheme="LG")`: on LG meshes;
    the fuel homotopy and method "condensed" on LGR or LG segments, a fuel-optimal LGL
    ladder by the augmented Lagrangian). method: None for the family's default (minimum
    time: "condensed" on a `SegmentedMesh`; fuel-optimal: "augmented-lagrangian" with safety
    constraints or on LGL segments). options: the
    method's frozen options object (`NewtonOptions`, `ALOptions`, `HomotopyOptions`,
    `FuelALOptions`, `CondensedOptions`) or None for its defaults.
    tolerance: a `Tolerance` (SI: position m, velocity m/s; None: `DEFAULT_TOLERANCE`): a
    converged solution whose error estimate between the nodes exceeds it is INACCURATE.
    throw: an unbatched, concrete solve that does not end SUCCESS raises `SolveError` (its
    `.status` and `.solution` say what happened); throw=False returns the solution with its
    status. Under jit/vmap/grad nothing raises: the status is per member.
    Concrete bad input raises ValueError; traced bad input gives status INVALID_INPUT.
    """
    require_x64()
    family = FAMILIES.get(type(problem))
    if family is None:
        names = ", ".join(sorted(p.__name__ for p in FAMILIES))
        raise ValueError(f"solve takes a problem of one of the families {names}, got "
                         f"{type(problem).__name__}")
    tolerance = DEFAULT_TOLERANCE if tolerance is None else tolerance
    if not isinstance(tolerance, Tolerance):
        raise ValueError(f"tolerance must be a jaxlpm Tolerance, got {tolerance!r:.60}")
    solution = family.solve(problem, grid, method, options, Judge(tolerance))
    if (throw and is_concrete(solution.status) and np.ndim(solution.status) == 0
            and int(solution.status) != Status.SUCCESS):
        raise SolveError(solution)
    return solution
