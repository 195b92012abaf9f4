"""Verification: propagate interpolated controls through linear and nonlinear models; solve
a problem's necessary conditions by shooting (an answer independent of any grid)."""

from .indirect import ShootingResult, min_time_shooting
from .propagate import (PAD_TO, ControlInterpolant, control_interpolant, propagate_linear,
                        propagate_nonlinear, terminal_error)

__all__ = ["PAD_TO", "ControlInterpolant", "ShootingResult", "control_interpolant",
           "min_time_shooting", "propagate_linear", "propagate_nonlinear", "terminal_error"]
