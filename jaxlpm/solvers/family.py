"""What `jaxlpm.solve` needs to know of a problem family: its methods, their options, its
default grid, and the compiled solver that turns (problem, grid, method, options) into a
`Solution`."""

from dataclasses import dataclass
from typing import Callable

from .._validation import is_concrete
from .refine import MeshLadder


@dataclass(frozen=True)
class FamilySolver:
    """A problem family as `solve` dispatches it.

    problem       the problem class (its `check()` validates it)
    methods       {method name: options class, or None for a method without options}; the
                  first is the default unless `default_method` says otherwise
    run           (problem, grid, method, options) -> `Solution`; jit-compiled inside
    default_grid  problem -> the grid `solve(problem)` uses
    check_grid    (grid, method) -> None, raising ValueError for a grid the method cannot use
    default_method  optional (problem, grid) -> method name
    refine        optional (problem, options, judge) -> `Solution`: the mesh refinement
                  `solve(problem)` runs for a concrete problem without a grid, with the
                  method `refine_method` (`jaxlpm.solvers.refine`; judge a
                  `jaxlpm.solution.Judge`)
    refine_method the method refinement uses: a name, or (problem, ladder or None) -> name
    ladders       refine also takes a `MeshLadder` (the grid of `solve(problem, ladder)`)
    default_options  optional (method, grid or ladder, None for the default ladder) -> the
                  options of a solve that passes none (default: the options class's
                  defaults)
    """

    problem: type
    methods: dict
    run: Callable
    default_grid: Callable
    check_grid: Callable
    default_method: Callable | None = None
    refine: Callable | None = None
    refine_method: str | Callable | None = None
    ladders: bool = False
    default_options: Callable | None = None

    def solve(self, problem, grid, method, options, judge):
        """The solution of `problem` with `judge` (INACCURATE where the error estimate
        exceeds the tolerance) applied; grid a `MeshLadder`: refinement on that ladder."""
        ladder = grid if isinstance(grid, MeshLadder) else None
        refine_method = (self.refine_method(problem, ladder) if callable(self.refine_method)
                         else self.refine_method)
        if ladder is not None:
            if not self.ladders:
                raise ValueError(f"a MeshLadder refines energy-optimal, fuel-optimal and "
                                 f"minimum-time transfers; a {self.problem.__name__} refines "
                                 f"on its own ladder (solve(problem) without a grid)")
            if not is_concrete(problem) or method not in (None, refine_method):
                raise ValueError(f"refinement on a MeshLadder needs a concrete problem (not "
                                 f"under jit or vmap: use jaxlpm.batch.refine.refine_batch) "
                                 f"and the method {refine_method!r}, got method {method!r}")
            grid = None
        refining = (grid is None and self.refine is not None and is_concrete(problem)
                    and method in (None, refine_method))
        if refining:
            method = refine_method
        elif grid is None:
            grid = self.default_grid(problem)
        if method is None:
            method = (self.default_method(problem, grid) if self.default_method is not None
                      else next(iter(self.methods)))
        if method not in self.methods:
            raise ValueError(f"method must be one of {tuple(self.methods)} for a "
                             f"{self.problem.__name__}, got {method!r}")
        kind = self.methods[method]
        if kind is None and options is not None:
            raise ValueError(f"method {method!r} takes no options, got "
                             f"{type(options).__name__}")
        if kind is not None and options is None:
            options = (kind() if self.default_options is None
                       else self.default_options(method, ladder if refining else grid))
        if kind is not None:
            if not isinstance(options, kind):
                raise ValueError(f"options for method {method!r} must be a {kind.__name__}, "
                                 f"got {type(options).__name__}")
        problem.check()
        if refining:
            return self.refine(problem, options, judge,
                               *(() if ladder is None else (ladder,)))
        self.check_grid(grid, method)
        return judge(self.run(problem, grid, method, options))
