"""Transfer problem families: what each asks (fields in SI, LVLH), its checks and how it becomes
an NLP (`jaxlpm.nlp`)."""

from .min_time import MinimumTimeTransfer
from .energy_optimal import MODELS, EnergyOptimalTransfer, check_problem
from .intercept import FiniteBurnIntercept, ImpulsiveIntercept
from .lqr import LQRTransfer

__all__ = ["EnergyOptimalTransfer", "FiniteBurnIntercept", "ImpulsiveIntercept", "LQRTransfer",
           "MODELS", "MinimumTimeTransfer", "check_problem"]
