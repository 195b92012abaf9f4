"""Optimal-control problem definitions and their pseudospectral transcription."""

from .min_time import MinimumTimeTransfer
from .ocp import OptimalControlProblem, PathPenalty
from .transfer import MODELS, EnergyOptimalTransfer, check_problem

__all__ = ["EnergyOptimalTransfer", "MODELS", "MinimumTimeTransfer", "OptimalControlProblem",
           "PathPenalty", "check_problem"]
