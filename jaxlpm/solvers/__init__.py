"""Solvers. `solve(problem, grid, method)` is the public entry point."""

import jax

from .._validation import is_concrete, require_x64
from ..problems import check_problem
from .lq import kkt_law, stm_law
from .solution import Solution

LAWS = {"stm": stm_law, "kkt": kkt_law}
_COMPILED = {name: jax.jit(law) for name, law in LAWS.items()}
MIN_POINTS = 4   # the KKT law needs interior nodes beyond the 2 velocity conditions per axis


def solve(problem, grid, method: str = "kkt") -> Solution:
    """Solve an energy-optimal transfer on a grid; jit-compiled once per (method, grid size).

    method: "kkt" (Mei 2010 §3.2, collocated state equations) or "stm" (§3.1, Gramian of the
    Yamanaka-Ankersen STM). Concrete inputs are validated (ValueError); traced inputs under
    jit/vmap/grad give status INVALID_INPUT instead.
    """
    require_x64()
    if method not in LAWS:
        raise ValueError(f"method must be one of {sorted(LAWS)}, got {method!r}")
    if getattr(grid, "scheme", None) != "LGL":
        raise ValueError(f"the LQ laws are defined on LGL grids (lgl(n)), got {grid!r:.60}")
    if grid.n < MIN_POINTS:
        raise ValueError(f"the LQ laws need at least {MIN_POINTS} LGL points (N >= "
                         f"{MIN_POINTS - 1}), got {grid.n}")
    check_problem(problem)
    if is_concrete(problem, grid):
        return _COMPILED[method](problem, grid)
    return LAWS[method](problem, grid)


__all__ = ["LAWS", "MIN_POINTS", "Solution", "kkt_law", "solve", "stm_law"]
