"""Design under uncertainty (`optimise`): mission parameters chosen by an optax optimiser so
that a risk measure (`risk`: mean, mean + k std, CVaR) of the per-member cost or delta-v over
a dispersion of problems is least, through batched solves and their implicit gradients."""

from .brute_force import BruteForce, brute_force
from .optimise import DesignProblem, DesignResult, evaluate, optimise
from .risk import CVaR, Mean, MeanStd, cvar, mean, mean_std

__all__ = ["BruteForce", "CVaR", "DesignProblem", "DesignResult", "Mean", "MeanStd", "cvar", "mean",
           "mean_std", "brute_force", "evaluate", "optimise"]
