"""The one result of every transfer family (`Solution`) and the trajectories that evaluate it
between the nodes (`collocated`: one grid or a segmented mesh; `hamiltonian`: the exact flow
of a linear-quadratic solution)."""

from .accuracy import DEFAULT_TOLERANCE, Judge, Tolerance, accuracy_stats, judge
from .collocated import (PAD_TO, Collocated, ControlInterpolant, MeshControl,
                         control_interpolant)
from .hamiltonian import FlowControl, HamiltonianFlow
from .intercept import Burn, FiniteBurn, Impulse
from .solution import Solution, SolveError, zero_invalid

__all__ = ["DEFAULT_TOLERANCE", "Judge", "Tolerance", "accuracy_stats", "judge", "MeshControl",
           "Burn", "Collocated", "ControlInterpolant", "FiniteBurn", "FlowControl",
           "HamiltonianFlow", "Impulse", "PAD_TO", "Solution",
           "SolveError", "control_interpolant", "zero_invalid"]
