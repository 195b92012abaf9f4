"""jaxlpm: pseudospectral optimal spacecraft relative-orbit transfers in JAX.

Frames and units at the interface: LVLH relative states [x, y, z, vx, vy, vz] in m and m/s
(x radial outward, y along-track, z orbit normal), controls in m/s^2, times in s since the
start of the transfer, angles in rad; the J2 intercepts (`ImpulsiveIntercept`,
`FiniteBurnIntercept`) are posed in the Earth-centred inertial frame (equatorial), their
`Solution.frame` "inertial". float64 only: enable it with
jax.config.update("jax_enable_x64", True).

A research script needs only `import jaxlpm as lpm`: a problem (`EnergyOptimalTransfer`,
`MinimumTimeTransfer`, `FuelOptimalTransfer`, `LQRTransfer`, `ImpulsiveIntercept`,
`FiniteBurnIntercept`), optional safety constraints on an energy-optimal transfer
(`KeepOutEllipsoid`, `ApproachCone`, `SpeedLimit`, `ThrustLimit`, `PassiveSafety`), a grid
(`lgl(n)`, `lg(n)`, `lgr(n)`: n points; `lgr_mesh(k, n)`, `lg_mesh(k, n)`, `lgl_mesh(k, n)`:
k segments; `segmented_lgr`, `segmented_lg`, `segmented_lgl`), `solve(problem, grid)` ->
`Solution` (without a grid: adaptive mesh refinement to the `Tolerance`; a solution that
converged but misses it is INACCURATE), `verify.fly(solution)`, `batch` (sweeps, Monte
Carlo), `design` (mission parameters optimised under uncertainty by optax), `io` (save/load,
CSV, CCSDS OEM), `lambert`, `Status`, `plot` (figures of solutions and studies; matplotlib is
imported only when a figure is drawn).
"""

from . import _cpu_runtime

_cpu_runtime.apply()

from . import constants  # noqa: E402
from .collocation import Grid, lg, lgl, lgr, make_grid  # noqa: E402
from .collocation.segments import (LGLMesh, LGMesh, LGRMesh, Mesh, SegmentedMesh,  # noqa: E402
                                   aligned_breaks, lg_mesh, lgl_mesh, lgr_mesh, make_mesh,
                                   segmented_lg, segmented_lgl, segmented_lgr, segmented_mesh,
                                   uniform_breaks)
from .nlp import ALOptions, HomotopyOptions, NewtonOptions, OptimalControlProblem  # noqa: E402
from .orbits import KeplerOrbit  # noqa: E402
from .orbits.lambert import LambertSolution, lambert  # noqa: E402
from .problems import (EnergyOptimalTransfer, FiniteBurnIntercept,  # noqa: E402
                       ImpulsiveIntercept, LQRTransfer, MinimumTimeTransfer)
from .problems.fuel_optimal import FuelOptimalTransfer  # noqa: E402
from .problems.safety import (ApproachCone, KeepOutEllipsoid, PassiveSafety,  # noqa: E402
                              SpeedLimit, ThrustLimit)
from .solution import DEFAULT_TOLERANCE, Solution, SolveError, Tolerance  # noqa: E402
from .solvers import solve  # noqa: E402
from .solvers.refine import DEFAULT_LADDER, MeshLadder  # noqa: E402
from .solvers.finite_burn import FiniteBurnOptions  # noqa: E402
from .solvers.fuel_constrained import FuelALOptions  # noqa: E402
from .solvers.fuel_optimal import (burn_arcs, indirect_fuel_optimal, primer,  # noqa: E402
                                   refine_fuel_optimal, switching_function, switching_times)
from .solvers.lqr import hcw_lqr  # noqa: E402
from .solvers.min_time_condensed import CondensedOptions, min_time_shooting  # noqa: E402
from .solvers.riccati import CareSolution, care  # noqa: E402
from .status import Status, describe  # noqa: E402
from . import batch, compilation, design, io, nlp, plot, verify  # noqa: E402

__version__ = "0.2.0"
"""The package version."""

__all__ = [
    "DEFAULT_LADDER", "DEFAULT_TOLERANCE", "LGLMesh", "LGMesh", "LGRMesh", "Mesh", "MeshLadder",
    "Tolerance", "lg_mesh", "lgl_mesh", "lgr_mesh", "make_mesh",
    "ALOptions", "ApproachCone", "CareSolution", "CondensedOptions", "EnergyOptimalTransfer", "FiniteBurnIntercept",
    "FiniteBurnOptions", "FuelALOptions", "FuelOptimalTransfer", "Grid", "HomotopyOptions",
    "ImpulsiveIntercept", "KeepOutEllipsoid", "KeplerOrbit", "LQRTransfer", "LambertSolution",
    "MinimumTimeTransfer", "NewtonOptions", "OptimalControlProblem", "PassiveSafety",
    "SegmentedMesh",
    "Solution", "SolveError", "SpeedLimit", "Status", "ThrustLimit", "__version__", "aligned_breaks", "batch", "burn_arcs",
    "care", "compilation", "constants", "describe", "design", "hcw_lqr",
    "indirect_fuel_optimal", "io", "lambert", "lg",
    "lgl", "lgr", "make_grid", "min_time_shooting", "nlp", "plot", "primer", "refine_fuel_optimal",
    "segmented_lg", "segmented_lgl", "segmented_lgr", "segmented_mesh",
    "solve", "switching_function", "switching_times", "uniform_breaks", "verify",
]
