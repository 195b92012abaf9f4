"""Problem families' solvers behind the one entry point `solve`; each returns a `Solution`."""

from ..solution import Solution, SolveError
from .api import FAMILIES, solve

__all__ = ["FAMILIES", "Solution", "SolveError", "solve"]
