"""Optimal-control problem definitions and their pseudospectral transcription."""

from .ocp import OptimalControlProblem
from .transfer import MODELS, EnergyOptimalTransfer, check_problem

__all__ = ["EnergyOptimalTransfer", "MODELS", "OptimalControlProblem", "check_problem"]
