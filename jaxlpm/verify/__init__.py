"""Verification: fly a solution through a dynamics model with an independent integrator
(`fly`); solve a problem's necessary conditions by shooting (an answer independent of any
grid)."""

from .fly import Flight, fly, propagate_linear, propagate_nonlinear, terminal_error
from .indirect import ShootingResult, min_time_shooting

__all__ = ["Flight", "ShootingResult", "fly", "min_time_shooting", "propagate_linear",
           "propagate_nonlinear", "terminal_error"]
