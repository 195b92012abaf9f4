"""LGL grids padded to a fixed capacity, so that one compiled program serves grids of every size
up to it (issue 21: `jaxlpm reproduce mei2010` solves each LQ law on 7 grids; compiled per
grid that was 14 programs, about a third of a cold run).

A `PaddedGrid` holds lgl(n) in arrays of capacity M >= n:

    rows 0 .. n-2        the grid's first n - 1 points
    rows n-1 .. M-2      padding: tau = +1, quadrature and barycentric weights 0, zero rows and
                         columns in D and in the integration matrix
    row  M-1             the grid's last point (tau = +1)

so that the first and the last row are the grid's own ends, the padding takes no part in a
quadrature, a barycentric interpolant (`barycentric_interpolate` skips zero weights), a
derivative or an integral, and n is an array leaf: the program's shapes depend on M alone.
Where the padding's own unknowns must stay decoupled from the grid's (a least-squares solve),
the code reads `padding(grid)`. `pad_rows` puts node values in the padded layout and
`grid_rows(n, M)` gathers a padded result back onto lgl(n).
"""

import dataclasses
import functools

import jax
import jax.numpy as jnp
import numpy as np

from .grid import Grid, lgl

# Every LGL grid up to this many points is padded to it: mei2010's grids (9 to 129 points)
# share one program per law. Larger grids pad to the next 2^k + 1 points.
MIN_CAPACITY = 129


@dataclasses.dataclass(frozen=True, eq=False)
class PaddedGrid(Grid):
    """lgl(live) padded to n = M points (module docstring); `Grid`'s operators with the
    padding's rows and columns in place, and `live` (int32 array) the grid's own number of
    points. A pytree whose leaves are the operators and `live` (static: "LGL" and M)."""

    live: jax.Array = None


jax.tree_util.register_pytree_node(
    PaddedGrid,
    lambda g: ((g.points, g.weights, g.support, g.D, g.support_bary, g.point_bary,
                g.integration, g.live), g.n),
    lambda n, leaves: PaddedGrid("LGL", n, *leaves))


def capacity(n: int, minimum: int = MIN_CAPACITY) -> int:
    """The capacity lgl(n) is padded to: `minimum` (2^k + 1), or the next 2^k + 1 above it."""
    m = minimum
    while m < n:
        m = 2 * (m - 1) + 1
    return m


@functools.lru_cache(maxsize=None)
def grid_rows(n: int, m: int) -> np.ndarray:
    """The rows of a capacity-m padded grid that hold lgl(n)'s points, in order."""
    rows = np.concatenate([np.arange(n - 1), [m - 1]])
    rows.setflags(write=False)
    return rows


def pad_rows(values, m: int, fill=None) -> np.ndarray:
    """lgl(n)'s node values (n, ...) in the rows of a capacity-m padded grid (host array); the
    padding rows hold `fill`, or (None) a copy of the last row (finite, weighted by zero)."""
    values = np.asarray(values)
    out = (np.repeat(values[-1:], m, axis=0) if fill is None
           else np.full((m, *values.shape[1:]), fill, values.dtype))
    out[grid_rows(values.shape[0], m)] = values
    return out


@functools.lru_cache(maxsize=None)
def pad_grid(n: int, m: int | None = None) -> PaddedGrid:
    """lgl(n) as a `PaddedGrid` of capacity m (default `capacity(n)`); host (NumPy) arrays."""
    m = capacity(n) if m is None else m
    if m < n:
        raise ValueError(f"capacity {m} is smaller than the grid's {n} points")
    grid, rows = lgl(n), grid_rows(n, m)

    def matrix(values):
        out = np.zeros((m, m))
        out[np.ix_(rows, rows)] = values
        return out

    points = pad_rows(grid.points, m, 1.0)
    ops = dict(points=points, weights=pad_rows(grid.weights, m, 0.0), support=points,
               D=matrix(grid.D), support_bary=pad_rows(grid.support_bary, m, 0.0),
               point_bary=pad_rows(grid.point_bary, m, 0.0),
               integration=matrix(grid.integration),
               live=np.asarray(n, np.int32))
    for arr in ops.values():
        arr.setflags(write=False)
    return PaddedGrid("LGL", m, **ops)


def padding(grid):
    """(n,) True on the padding rows of a `PaddedGrid`; None for any other grid."""
    if not isinstance(grid, PaddedGrid):
        return None
    i = jnp.arange(grid.n)
    return (i >= grid.live - 1) & (i < grid.n - 1)
