"""The one result of every transfer family (`Solution`) and the trajectories that evaluate it
between the nodes (`collocated`: one grid or a segmented mesh)."""

from .collocated import (PAD_TO, Collocated, ControlInterpolant, Segmented, SegmentedControl,
                         control_interpolant)
from .intercept import Burn, FiniteBurn, Impulse
from .solution import Solution, SolveError, zero_invalid

__all__ = ["Collocated", "ControlInterpolant", "PAD_TO", "Segmented", "SegmentedControl",
           "Solution", "SolveError", "control_interpolant", "zero_invalid"]
__all__ += ["Burn", "FiniteBurn", "Impulse"]
