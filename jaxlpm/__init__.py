"""jaxlpm: pseudospectral optimal spacecraft relative-orbit transfers in JAX.

Frames and units at the interface: LVLH relative states [x, y, z, vx, vy, vz] in m and m/s
(x radial outward, y along-track, z orbit normal), controls in m/s^2, times in s, angles in
rad. float64 only: enable it with jax.config.update("jax_enable_x64", True).
"""

from . import _cpu_runtime

_cpu_runtime.apply()

from . import constants  # noqa: E402
from .collocation import Grid, lg, lgl, lgr, make_grid  # noqa: E402
from .orbits import KeplerOrbit  # noqa: E402
from .nlp import OptimalControlProblem  # noqa: E402
from .problems import EnergyOptimalTransfer, MinimumTimeTransfer  # noqa: E402
from .solvers import (ALOptions, MinimumTimeSolution, NewtonOptions, Solution,  # noqa: E402
                      TransferSolution, augmented_lagrangian, min_time_transfer, newton_kkt,
                      solve)
from .solvers.lqr import Flight, finite_horizon_lqr, hcw_lqr, infinite_horizon_flight  # noqa: E402
from .solvers.riccati import CareSolution, care  # noqa: E402
from .status import Status, describe  # noqa: E402
from .collocation.segments import SegmentedMesh, segmented_lgr  # noqa: E402
from .problems.fuel_optimal import FuelOptimalTransfer  # noqa: E402
from .solvers.fuel_optimal import (FuelOptimalSolution, fuel_optimal_transfer,  # noqa: E402
                                   indirect_fuel_optimal, refine_fuel_optimal)
from .nlp.homotopy import HomotopyOptions  # noqa: E402

__version__ = "0.1.0"

__all__ = [
    "EnergyOptimalTransfer", "Grid", "KeplerOrbit", "NewtonOptions", "OptimalControlProblem",
    "Solution", "Status", "TransferSolution", "constants", "describe", "lg", "lgl", "lgr",
    "make_grid", "newton_kkt", "solve", "__version__",
    "ALOptions", "MinimumTimeSolution", "MinimumTimeTransfer", "augmented_lagrangian",
    "min_time_transfer",
    "CareSolution", "Flight", "care", "finite_horizon_lqr", "hcw_lqr", "infinite_horizon_flight",
    "FuelOptimalSolution", "FuelOptimalTransfer", "HomotopyOptions", "SegmentedMesh",
    "fuel_optimal_transfer", "indirect_fuel_optimal", "refine_fuel_optimal", "segmented_lgr",
]
