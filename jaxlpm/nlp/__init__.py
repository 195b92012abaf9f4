"""The problem-agnostic NLP engine: no orbital mechanics here (it imports only the bottom layer
and `jaxlpm.collocation`).

- `ocp`: the general optimal-control problem (dynamics, costs, boundary functions, path
  constraints) in a generic independent variable s.
- `transcription`: its pseudospectral transcription on LGL, LG and LGR grids (decision vector,
  defects, structured Jacobians and Lagrangian Hessians, costate estimates).
- `newton`: the Newton-KKT (SQP) iteration with the dense KKT solve, continuation, implicit
  differentiation; `condensed`: the null-space (condensed) KKT solve for fully actuated
  second-order problems; `condensed_segments`: the same step on many-segment LGR meshes,
  its reduced Hessian block-banded (`SegmentedCondensed`; `condensed_linear_algebra` picks
  the class).
- `augmented_lagrangian`: path inequalities/equalities and final-s bounds around the Newton
  iteration.
- `homotopy`: the smoothed-L1 (energy-to-fuel) continuation on a condensed linear problem.
"""

from .augmented_lagrangian import ALOptions, ALResult, augmented_lagrangian
from .condensed import CondensedSecondOrder
from .condensed_segments import SegmentedCondensed, condensed_linear_algebra
from .homotopy import HomotopyOptions, energy_to_fuel
from .newton import DenseKKT, NLPResult, NewtonOptions, newton_kkt, newton_step
from .ocp import OptimalControlProblem, PathPenalty

__all__ = ["ALOptions", "ALResult", "CondensedSecondOrder", "DenseKKT", "HomotopyOptions",
           "NLPResult", "NewtonOptions", "OptimalControlProblem", "PathPenalty",
           "SegmentedCondensed", "augmented_lagrangian", "condensed_linear_algebra",
           "energy_to_fuel", "newton_kkt", "newton_step"]
