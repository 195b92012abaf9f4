"""The design objective on a grid of theta values by the sweep engine: the reference an
optimiser's answer is checked against (`optimise`), with the same samples at every cell
(common random numbers: the dispersion's draws from one key).

Every cell's batch (design.dispersion(key, theta_cell)) becomes members of one
`jaxlpm.batch.sweep` (chunked, resumable with `out`); each member records its status and
quantity; a cell's objective is design.risk over its SUCCESS members.
"""

from dataclasses import dataclass
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from ..batch.family import SweepFamily, problem_table
from ..batch.sweep import parameter_grid, sweep
from ..solution import DEFAULT_TOLERANCE
from ..solvers import solve
from ..status import Status
from .optimise import QUANTITIES, design_grid


@dataclass
class BruteForce:
    """The objective over a grid of theta values.

    axes       {name: 1-D values} (theta's keys), the first axis slowest
    objective  design.risk of each cell (shape: one axis per name), NaN where no member
               ended SUCCESS
    success    SUCCESS members per cell (same shape); members: samples per cell
    out        the sweep's results directory, or None
    """

    axes: dict
    objective: np.ndarray
    success: np.ndarray
    members: int
    out: Path | None = None

    @property
    def solves(self) -> int:
        """Member solves made (cells x members)."""
        return int(self.objective.size * self.members)

    @property
    def argmin(self) -> dict:
        """{name: value} of the cell with the least objective."""
        index = np.unravel_index(np.nanargmin(self.objective), self.objective.shape)
        return {name: float(values[i]) for (name, values), i in zip(self.axes.items(), index)}

    @property
    def spacing(self) -> dict:
        """{name: the grid's step along that axis} (0 for a single value)."""
        return {name: float(np.ptp(v) / max(len(v) - 1, 1)) for name, v in self.axes.items()}


def _family(design, grid, definition, build):
    quantity = (QUANTITIES[design.quantity] if isinstance(design.quantity, str)
                else design.quantity)
    tolerance = DEFAULT_TOLERANCE if design.tolerance is None else design.tolerance

    def solver(problem, grid_, method, options):
        return solve(problem, grid_, method=method, options=options, tolerance=tolerance,
                     throw=False)

    def record(solution):
        return dict(status=solution.status, quantity=quantity(solution))

    return SweepFamily(name="design-brute-force", build=build, grid=lambda n: grid,
                       method=design.method, options=design.options, record=record,
                       definition=definition, solver=solver)


def brute_force(design, key, axes: dict, *, out=None, chunk_size: int = 256,
                progress: bool = True) -> BruteForce:
    """design's objective at every cell of the grid `axes` ({name: 1-D values}; theta is the
    dict {name: scalar}) with the samples of `key` at every cell (module docstring)."""
    cells = parameter_grid(**axes)
    theta = {name: jnp.asarray(v) for name, v in cells.items()}
    problems = jax.vmap(lambda th: design.dispersion(key, th))(theta)
    n_cells = next(iter(cells.values())).size
    members = jax.tree_util.tree_leaves(problems)[0].shape[1]
    flat = jax.tree_util.tree_map(lambda x: x.reshape((n_cells * members,) + x.shape[2:]),
                                  problems)
    one = jax.tree_util.tree_map(lambda x: x[0], flat)
    grid = design_grid(design, one)
    params, build = problem_table(flat)
    definition = dict(design.definition({k: 0.0 for k in axes}, key, True),
                      axes={k: np.asarray(v).tolist() for k, v in axes.items()})
    family = _family(design, grid, definition, build)
    result = sweep(family, params, [grid.n], out=out, chunk_size=chunk_size,
                   progress=progress)
    table = result.tables[grid.n]
    shape = tuple(len(v) for v in axes.values())
    q = jnp.asarray(table["quantity"]).reshape(n_cells, members)
    ok = (table["status"] == Status.SUCCESS).reshape(n_cells, members) & np.isfinite(
        np.asarray(q))
    objective = np.asarray(jax.vmap(design.risk)(jnp.where(ok, q, 0.0),
                                                 jnp.asarray(ok, q.dtype)))
    success = ok.sum(axis=1)
    objective = np.where(success > 0, objective, np.nan)
    return BruteForce(axes={k: np.asarray(v, float) for k, v in axes.items()},
                      objective=objective.reshape(shape), success=success.reshape(shape),
                      members=members, out=None if out is None else Path(out))
