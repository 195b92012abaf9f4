"""Optimal-control problem definitions."""

from .transfer import EnergyOptimalTransfer, check_problem

__all__ = ["EnergyOptimalTransfer", "check_problem"]
