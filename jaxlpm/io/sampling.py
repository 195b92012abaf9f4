"""Where a table or an ephemeris samples one solution: the times (s since the start) and the
solution's states and controls there (in its frame, SI)."""

import numpy as np

from ..compilation import compiled

DEFAULT_SAMPLES = 201
"""Uniform samples over [0, duration] when an export is given no times."""


def single(solution, what: str) -> None:
    """ValueError unless `solution` is one (unbatched) Solution."""
    shape = np.shape(solution.status)
    if shape:
        raise ValueError(f"{what} takes one solution, got a batch of shape {shape}: pick a "
                         f"member, e.g. jax.tree_util.tree_map(lambda x: x[i], solution)")


def sample_times(solution, times=None) -> np.ndarray:
    """`times` (s since the start; a scalar or 1-D, finite, in [0, duration]) as a float64
    NumPy array, or DEFAULT_SAMPLES uniform times from 0 to the duration; ValueError
    otherwise."""
    duration = float(np.asarray(solution.duration))
    if times is None:
        return np.linspace(0.0, duration, DEFAULT_SAMPLES)
    try:
        t = np.atleast_1d(np.asarray(times, dtype=np.float64))
    except (TypeError, ValueError):
        raise ValueError(f"times must be real numbers (s), got {times!r:.80}") from None
    if t.ndim != 1 or t.size == 0:
        raise ValueError(f"times must be a scalar or a non-empty 1-D array (s), got shape "
                         f"{t.shape}")
    if not (np.all(np.isfinite(t)) and np.all(t >= 0.0) and np.all(t <= duration)):
        raise ValueError(f"times must lie in [0, duration] = [0, {duration:.17g}] s (since the "
                         f"start of the transfer), got {t}")
    return t


@compiled
def evaluate(solution, t):
    """(states (len(t), 6), controls (len(t), 3)) of one solution at times t (s), compiled
    once per solution structure and number of times."""
    return solution.states(t), solution.controls(t)
