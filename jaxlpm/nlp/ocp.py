"""A general optimal-control problem in one independent variable s (Bolza form).

    minimise    J = int_{s0}^{sf} L(s, x, u) ds + phi(x(s0), x(sf), sf)
    subject to  dx/ds = F(s, x, u),   b(x(s0), x(sf), sf) = 0,
                g(s, x, u) <= 0,   h(s, x, u) = 0   (path, at every collocation point),
                sf_min <= sf <= sf_max              (free final s only)

The problem is written in the solver's own (nondimensional) units: the builders of physical
problems (`jaxlpm.problems.energy_optimal`) scale SI inputs before they get here. s may be time,
true anomaly or a regularised variable; with `free_final` the final value sf is a decision
variable (time scaling s = s0 + (sf - s0)(tau + 1)/2 on the grid's tau in [-1, 1]).

Callables are static (hashable module-level functions: one compiled solver per problem class),
everything numeric is an array leaf. Per-point data the right-hand side needs but cannot compute
cheaply from s (a chief's ephemeris integrated under J2) is passed in `node_data`: a pytree with
leading axis = the grid's number of collocation points, handed to F, L and g point by point.
"""

from dataclasses import dataclass, field, replace
from typing import Any, Callable, Optional

import jax


def _static(default=None):
    return field(default=default, metadata=dict(static=True))


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class OptimalControlProblem:
    """Problem description; see the module docstring.

    n_x, n_u       state and control dimensions (static)
    dynamics       F(s, x, u, data, params) -> dx/ds, shape (n_x,)
    running_cost   L(s, x, u, data, params) -> scalar integrand per unit s
    boundary       b(x0, xf, sf, params) -> (n_b,) residuals, = 0 at the solution
    s0, sf         interval of the independent variable (sf: the initial guess if free_final)
    params         pytree of array leaves the callables read (sweepable, differentiable)
    node_data      pytree with leading axis = number of collocation points, or None;
                   None is required with free_final (points move with sf)
    path           g(s, x, u, data, params) -> (n_g,), <= 0 (None: no path constraints)
    terminal_cost  phi(x0, xf, sf, params) -> scalar (None: 0)
    free_final     sf is a decision variable (static)
    path_equality  h(s, x, u, data, params) -> (n_h,), = 0 (None: none), e.g. |u|^2 - 1
    final_bounds   (2,) [sf_min, sf_max] with free_final (None: unbounded); +-inf allowed
    penalty        `PathPenalty`: set by the augmented-Lagrangian solver on its inner
                   problems (leave None); with it the objective carries the path terms
    """

    n_x: int = _static()
    n_u: int = _static()
    dynamics: Callable = _static()
    running_cost: Callable = _static()
    boundary: Callable = _static()
    s0: jax.Array = None
    sf: jax.Array = None
    params: Any = None
    node_data: Any = None
    path: Optional[Callable] = _static()
    terminal_cost: Optional[Callable] = _static()
    free_final: bool = _static(False)
    path_equality: Optional[Callable] = _static()
    final_bounds: Any = None
    penalty: Any = None

    @property
    def has_path_constraints(self) -> bool:
        """Whether the problem has constraints beyond the equalities (path or bounds)."""
        return (self.path is not None or self.path_equality is not None
                or self.final_bounds is not None)

    def replace(self, **kwargs) -> "OptimalControlProblem":
        return replace(self, **kwargs)

    def validate(self) -> None:
        """Raise ValueError for an inconsistent description (Python boundary)."""
        for name in ("n_x", "n_u"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
        for name in ("dynamics", "running_cost", "boundary"):
            if not callable(getattr(self, name)):
                raise ValueError(f"{name} must be a callable, got {getattr(self, name)!r}")
        for name in ("path", "path_equality", "terminal_cost"):
            value = getattr(self, name)
            if value is not None and not callable(value):
                raise ValueError(f"{name} must be a callable or None, got {value!r}")
        if self.final_bounds is not None and not self.free_final:
            raise ValueError("final_bounds bound a free final s: set free_final=True or drop "
                             "them")
        if self.free_final and self.node_data is not None:
            raise ValueError("node_data is tied to fixed collocation points: it cannot be "
                             "combined with free_final (the points move with sf)")


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class PathPenalty:
    """Powell-Hestenes-Rockafellar terms the augmented-Lagrangian solver adds to the objective
    (Nocedal & Wright 2006, eq. 17.65 and 17.39; Birgin & Martinez 2014):

        sum_i [ max(0, mu_i + rho g_i)^2 - mu_i^2 ] / (2 rho)  +  sum_i [ nu_i h_i + rho h_i^2 / 2 ]

    over the path values at every collocation point and the final-s bounds.

    inequality  (n, n_g) multipliers mu >= 0 of g <= 0 at the collocation points
    equality    (n, n_h) multipliers nu of h = 0
    bounds      (2,) multipliers of sf_min - sf <= 0 and sf - sf_max <= 0
    rho         penalty parameter
    """

    inequality: jax.Array
    equality: jax.Array
    bounds: jax.Array
    rho: jax.Array
