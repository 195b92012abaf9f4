"""Verification: propagate interpolated controls through linear and nonlinear models."""

from .propagate import (PAD_TO, ControlInterpolant, control_interpolant, propagate_linear,
                        propagate_nonlinear, terminal_error)

__all__ = ["PAD_TO", "ControlInterpolant", "control_interpolant", "propagate_linear",
           "propagate_nonlinear", "terminal_error"]
