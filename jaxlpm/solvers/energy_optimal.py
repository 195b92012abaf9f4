"""Energy-optimal transfers (`EnergyOptimalTransfer`): which method solves which model and grid.

"kkt" (Mei 2010 §3.2, collocated state equations) and "stm" (§3.1, Gramian of the
Yamanaka-Ankersen STM) are the closed-form laws of the linear (Tschauner-Hempel) model on LGL
grids (`jaxlpm.solvers.lq`); "newton" is the Newton-KKT solver of the NLP engine on any model
("linear", "two-body", "j2") and grid (LGL, LG, LGR) (`jaxlpm.solvers.transfer`). Each is
jit-compiled once per (method, grid, options). Default: "kkt" for the linear model on an LGL
grid, "newton" otherwise; default grid lgl(65) (Mei 2010's N = 64).

`Solution.stats`: node_f / node_s (the independent variable at the collocation points, rad),
cost_true_anomaly (k^2 cost, m^2/s^4: Mei 2010 eq. 8's normalisation), multipliers,
constraint_residual, stationarity_residual, and per method: rcond, node_states_th,
costates_th (the laws), iterations, history, costates_scaled (Newton-KKT).
"""

import functools

import jax

from ..collocation import Grid, lgl
from ..nlp.newton import NewtonOptions
from ..problems import EnergyOptimalTransfer
from .family import FamilySolver
from .lq import kkt_law, stm_law
from .transfer import newton_transfer

DEFAULT_POINTS = 65            # Mei 2010's N = 64
MIN_LAW_POINTS = 4   # the KKT law needs interior nodes beyond the 2 velocity conditions per axis
MIN_NEWTON_POINTS = {"LGL": 4, "LG": 3, "LGR": 3}
_LAWS = {"stm": jax.jit(stm_law), "kkt": jax.jit(kkt_law)}


@functools.partial(jax.jit, static_argnames="options")
def _newton(problem, grid, options):
    return newton_transfer(problem, grid, options)


def default_method(problem, grid):
    """The KKT law for the linear model on an LGL grid, Newton-KKT otherwise."""
    return "kkt" if problem.model == "linear" and grid.scheme == "LGL" else "newton"


def check_grid(grid, method):
    if not isinstance(grid, Grid):
        raise ValueError(f"grid must be a jaxlpm Grid (lgl(n), lg(n), lgr(n): n points), got "
                         f"{grid!r:.60}")
    if method == "newton":
        if grid.n < MIN_NEWTON_POINTS[grid.scheme]:
            raise ValueError(f"the Newton-KKT solver needs at least "
                             f"{MIN_NEWTON_POINTS[grid.scheme]} {grid.scheme} points, got "
                             f"{grid.n}")
    elif grid.scheme != "LGL":
        raise ValueError(f"the LQ laws are defined on LGL grids (lgl(n)), got {grid.scheme}")
    elif grid.n < MIN_LAW_POINTS:
        raise ValueError(f"the LQ laws need at least {MIN_LAW_POINTS} LGL points, got "
                         f"{grid.n}")


def run(problem, grid, method, options):
    """The method's compiled solver (traced input too: under an outer jit it inlines, under
    an eager vmap or grad it compiles one program instead of dispatching op by op)."""
    if method == "newton":
        return _newton(problem, grid, options)
    if problem.model != "linear":
        raise ValueError(f"the {method!r} law is linear: model must be 'linear', got "
                         f"{problem.model!r} (use method='newton' for nonlinear models)")
    return _LAWS[method](problem, grid)


FAMILY = FamilySolver(problem=EnergyOptimalTransfer,
                      methods={"kkt": None, "stm": None, "newton": NewtonOptions}, run=run,
                      default_grid=lambda problem: lgl(DEFAULT_POINTS), check_grid=check_grid,
                      default_method=default_method)
