"""Solvers. `solve(problem, grid, method)` is the public entry point."""

import jax

from .._validation import require_x64
from ..problems import check_problem
from ..collocation import Grid
from ..nlp.augmented_lagrangian import ALOptions, ALResult, augmented_lagrangian
from .lq import kkt_law, stm_law
from .min_time import min_time_transfer
from ..nlp.newton import NLPResult, NewtonOptions, newton_kkt, newton_step
from .solution import MinimumTimeSolution, Solution, TransferSolution
from .transfer import newton_transfer

LAWS = {"stm": stm_law, "kkt": kkt_law, "newton": newton_transfer}
_COMPILED = {name: jax.jit(law) for name, law in LAWS.items()}
MIN_POINTS = 4   # the KKT law needs interior nodes beyond the 2 velocity conditions per axis
MIN_NEWTON_POINTS = {"LGL": 4, "LG": 3, "LGR": 3}


def solve(problem, grid, method: str = "kkt"):
    """Solve an energy-optimal transfer on a grid; jit-compiled once per (method, grid size).

    method: "kkt" (Mei 2010 §3.2, collocated state equations) or "stm" (§3.1, Gramian of the
    Yamanaka-Ankersen STM): linear model, LGL grids, returns a `Solution`; "newton": the
    Newton-KKT solver on any model ("linear", "two-body", "j2") and grid (LGL, LG, LGR),
    returns a `TransferSolution`. Concrete inputs are validated (ValueError); traced inputs
    under jit/vmap/grad give status INVALID_INPUT instead.
    """
    require_x64()
    if method not in LAWS:
        raise ValueError(f"method must be one of {sorted(LAWS)}, got {method!r}")
    if not isinstance(grid, Grid):
        raise ValueError(f"grid must be a jaxlpm Grid (lgl(n), lg(k), lgr(k)), got {grid!r:.60}")
    check_problem(problem)
    if method == "newton":
        if grid.n < MIN_NEWTON_POINTS[grid.scheme]:
            raise ValueError(f"the Newton-KKT solver needs at least "
                             f"{MIN_NEWTON_POINTS[grid.scheme]} {grid.scheme} points, got {grid.n}")
    elif problem.model != "linear":
        raise ValueError(f"the {method!r} law is linear: model must be 'linear', got "
                         f"{problem.model!r} (use method='newton' for nonlinear models)")
    elif grid.scheme != "LGL":
        raise ValueError(f"the LQ laws are defined on LGL grids (lgl(n)), got {grid.scheme}")
    elif grid.n < MIN_POINTS:
        raise ValueError(f"the LQ laws need at least {MIN_POINTS} LGL points (N >= "
                         f"{MIN_POINTS - 1}), got {grid.n}")
    # traced too: under an outer jit this inlines; under an eager vmap or grad it compiles one
    # batched or differentiated program instead of dispatching op by op
    return _COMPILED[method](problem, grid)


__all__ = ["ALOptions", "ALResult", "LAWS", "MIN_POINTS", "MinimumTimeSolution", "NLPResult",
           "NewtonOptions", "Solution", "TransferSolution", "augmented_lagrangian", "kkt_law",
           "min_time_transfer", "newton_kkt", "newton_step", "newton_transfer", "solve",
           "stm_law"]
