"""Trajectories of collocated solutions: how a `Solution` on one grid or on a segmented LGR
mesh (`Collocated`) is evaluated at a time t (s since the start).

`Collocated`: the grid's state polynomial over its support (a `jaxlpm.collocation.Grid`, or a
`Mesh` (LGR, LG, LGL): one polynomial per segment) and the
barycentric control interpolant over its collocation points, in the grid coordinate tau in
[-1, 1]. How t maps to tau is the `clock`, the independent variable s the family was
transcribed in (s = s0 + (sf - s0) (tau + 1) / 2):
  "true-anomaly"  s is the Keplerian chief's true anomaly f(t) (Kepler's equation, exact);
  "uniform"       s is affine in t (s = n t for the HCW families);
  "tabulated"     s is the J2 chief's regularised anomaly; tau(t) inverts the interpolated
                  state-row times t(tau) (monotone; Newton kept inside a bracket).
The polynomial's coordinates are LVLH or, for Mei 2010's laws, Tschauner-Hempel states
(converted to LVLH at f). A constant-thrust family sets `magnitude` > 0: the engine flies the
interpolated direction at that magnitude (Duan & Dong 2011, §4).

`flight_control()` gives the control as the function a propagator calls inside its right-hand
side (`ControlInterpolant`): of the chief's anomaly integrated beside the state for the
anomaly clocks, of time otherwise; padded to at least PAD_TO points so that one compiled
propagator serves every grid size up to PAD_TO points (`jaxlpm.collocation.padded.capacity`).
`padded()` and `unpadded(grid)` move a trajectory on lgl(n) to and from its `PaddedGrid`.
"""

from dataclasses import dataclass, field, replace
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from .._validation import is_concrete
from ..collocation import Grid, barycentric_interpolate
from ..collocation.padded import MIN_CAPACITY, capacity, grid_rows, pad_grid, pad_rows
from ..collocation.segments import Mesh
from ..orbits import th_to_lvlh, true_anomaly_from_time

CLOCKS = ("true-anomaly", "uniform", "tabulated")
COORDINATES = ("lvlh", "tschauner-hempel")
PAD_TO = MIN_CAPACITY
"""The flight control's padded size (points): one compiled propagator serves grids up to
lgl(129)."""
_FAR = 10.0           # padded support points sit outside [-1, 1] with zero weight
_INVERSION_STEPS = 60  # safeguarded Newton on t(tau): bisection alone halves 2^-60


def _static(default):
    return field(default=default, metadata=dict(static=True))


def _unit(v, magnitude):
    """v, or its direction at `magnitude` where magnitude > 0."""
    norm = jnp.linalg.norm(v)
    return jnp.where(magnitude > 0.0, magnitude * v / jnp.where(norm > 0.0, norm, 1.0), v)


def _to_tau(x, x0, x1):
    """x in [x0, x1] -> tau in [-1, 1]."""
    return 2.0 * (x - x0) / (x1 - x0) - 1.0


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class ControlInterpolant:
    """u(x) = barycentric interpolant of `values` on `tau` mapped to x in [x0, x1] (x the
    time or the chief's anomaly, `variable`); with magnitude > 0 its direction at that
    magnitude. Padded entries sit outside [-1, 1] with zero weight."""

    tau: jax.Array
    bary: jax.Array
    values: jax.Array
    x0: jax.Array
    x1: jax.Array
    magnitude: jax.Array = 0.0
    variable: str = _static("time")

    def __call__(self, x):
        return _unit(barycentric_interpolate(self.tau, self.bary, self.values,
                                             _to_tau(x, self.x0, self.x1)), self.magnitude)


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class MeshControl:
    """u(x) on a `Mesh` mapped to x in [x0, x1]: the segment holding x, then its
    barycentric interpolant over the segment's points; with magnitude > 0 its direction at
    that magnitude."""

    mesh: Mesh
    values: jax.Array
    x0: jax.Array
    x1: jax.Array
    magnitude: jax.Array = 0.0
    variable: str = _static("time")

    def __call__(self, x):
        return _unit(self.mesh.interpolate_control(self.values, _to_tau(x, self.x0, self.x1)),
                     self.magnitude)


def take_rows(values, rows):
    """values[rows] gathered on the host and put back on the device (no compiled program)."""
    return jax.device_put(np.asarray(values)[rows])


def control_interpolant(grid, values, x0, x1, magnitude=0.0, variable="time"):
    """`values` (n, 3) at the grid's collocation points as a `ControlInterpolant` over
    [x0, x1], zero-padded to `padded_size(n)` points (a `Mesh`: a `MeshControl`)."""
    if isinstance(grid, Mesh):
        return MeshControl(grid, values, x0, x1, jnp.asarray(magnitude, values.dtype),
                           variable)
    pad = capacity(grid.n) - grid.n
    # host arrays where nothing is traced: a flight of a concrete solution pads without
    # compiling a pad per shape
    xp = np if is_concrete(grid, values, x0, x1, magnitude) else jnp
    return ControlInterpolant(
        tau=xp.pad(xp.asarray(grid.points), (0, pad), constant_values=_FAR),
        bary=xp.pad(xp.asarray(grid.point_bary), (0, pad)),
        values=xp.pad(values, ((0, pad), (0, 0))), x0=x0, x1=x1,
        magnitude=xp.asarray(magnitude, values.dtype), variable=variable)


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class Collocated:
    """A solution on one grid (module docstring).

    grid           the `Grid` (static: scheme and number of points)
    times          (n,) times of the collocation points (s)
    dt_dtau        (n,) dt/dtau at the collocation points (s), for quadratures in time
    node_controls  (n, 3) controls at `times` (m/s^2)
    node_costates  (n, 6) costates at `times` (SI, see `Solution.costates`)
    state_times    (n_rows,) times of the state rows (`jaxlpm.nlp.transcription.state_tau`)
    node_states    (n_rows, 6) LVLH states at `state_times` (m, m/s)
    polynomial     (n_rows, 6) the state rows in `coordinates` (TH: m and m/rad)
    s0, sf         the independent variable at the start and the end (rad, or s)
    orbit          the chief's `KeplerOrbit` (the true-anomaly clock and TH coordinates)
    magnitude      > 0: the control's constant magnitude (m/s^2); 0: none
    clock, coordinates  static (module docstring)
    """

    grid: Grid
    times: jax.Array
    dt_dtau: jax.Array
    node_controls: jax.Array
    node_costates: jax.Array
    state_times: jax.Array
    node_states: jax.Array
    polynomial: jax.Array
    s0: jax.Array
    sf: jax.Array
    orbit: Any = None
    magnitude: jax.Array = 0.0
    clock: str = _static("uniform")
    coordinates: str = _static("lvlh")

    NODE_FIELDS = ("times", "dt_dtau", "node_controls", "node_costates", "state_times",
                   "node_states", "polynomial")

    def padded(self) -> "Collocated":
        """This trajectory on lgl(n) with its grid a `PaddedGrid` and its node rows in the
        padded layout (the padding rows a copy of the last: finite, weighted by zero), host
        arrays: one compiled evaluation serves every grid up to the capacity. Concrete, one
        trajectory, an LGL `Grid` only."""
        padded = pad_grid(self.grid.n)
        return replace(self, grid=padded, **{k: pad_rows(getattr(self, k), padded.n)
                                             for k in self.NODE_FIELDS})

    def unpadded(self, grid: Grid) -> "Collocated":
        """The inverse of `padded`: this trajectory on a `PaddedGrid` of `grid` (= lgl(n)) as
        the trajectory on `grid`, its node rows gathered on the host (no compiled program)."""
        rows = grid_rows(grid.n, self.grid.n)
        return replace(self, grid=grid, **{k: take_rows(getattr(self, k), rows)
                                           for k in self.NODE_FIELDS})

    def _support(self, rows):
        """The state rows that carry the polynomial (LG's last row does not)."""
        return rows[: self.grid.support.shape[0]]

    def tau(self, t):
        """Grid coordinate of time t (s) in [0, duration]."""
        if self.clock == "uniform":
            return 2.0 * t / self.state_times[-1] - 1.0
        if self.clock == "true-anomaly":
            f = true_anomaly_from_time(self.orbit, t)
            return 2.0 * (f - self.s0) / (self.sf - self.s0) - 1.0
        return self._invert_time(t)

    def _invert_time(self, t):
        """tau with t(tau) = t for the interpolated state-row times (monotone on [-1, 1]):
        Newton's method kept inside a shrinking bracket (bisection where Newton leaves it)."""
        support = self._support(self.state_times)

        def step(_, s):
            lo, hi, tau = s
            r, slope = jax.jvp(lambda x: self.grid.interpolate_state(support, x), (tau,),
                               (jnp.ones_like(tau),))
            lo = jnp.where(r < t, tau, lo)
            hi = jnp.where(r < t, hi, tau)
            newton = tau - (r - t) / jnp.where(slope > 0.0, slope, 1.0)
            ok = (slope > 0.0) & (newton > lo) & (newton < hi)
            return lo, hi, jnp.where(ok, newton, 0.5 * (lo + hi))

        one = jnp.ones_like(t)
        tau0 = 2.0 * t / self.state_times[-1] - 1.0
        return jax.lax.fori_loop(0, _INVERSION_STEPS, step, (-one, one, tau0))[2]

    def state(self, t):
        """LVLH state (m, m/s) at time t."""
        tau = self.tau(t)
        x = self.grid.interpolate_state(self._support(self.polynomial), tau)
        if self.coordinates == "tschauner-hempel":
            f = self.s0 + 0.5 * (self.sf - self.s0) * (tau + 1.0)
            x = th_to_lvlh(x, f, self.orbit.e, self.orbit.k2)
        return x

    def control(self, t):
        """Control (m/s^2) at time t."""
        return _unit(self.grid.interpolate_control(self.node_controls, self.tau(t)),
                     self.magnitude)

    def costate(self, t):
        """Costate estimate at time t, interpolated over the collocation points."""
        return self.grid.interpolate_control(self.node_costates, self.tau(t))

    def delta_v(self):
        """int |u| dt (m/s) by the grid's quadrature."""
        speed = jnp.linalg.norm(self.node_controls, axis=-1)
        return jnp.sum(self.grid.weights * self.dt_dtau * speed, axis=-1)

    def step_times(self):
        """Times (s) of the middles (in tau) of a `Mesh`'s segments, which a flight of the
        control steps to (`jaxlpm.verify.fly`), so that no adaptive step passes over a
        segment, and a short burn in it, unseen; None on a single grid."""
        if not isinstance(self.grid, Mesh):
            return None
        middles = 0.5 * (self.grid.breaks[1:] + self.grid.breaks[:-1])
        if self.clock == "uniform":
            return 0.5 * (middles + 1.0) * self.state_times[-1]
        return jax.vmap(lambda tau: self.grid.interpolate_state(
            self._support(self.state_times), tau))(middles)

    def flight_control(self) -> ControlInterpolant:
        """The control as a propagator calls it: of the chief's anomaly for the anomaly
        clocks, of time for the uniform one."""
        if self.clock == "uniform":
            return control_interpolant(self.grid, self.node_controls, 0.0 * self.s0,
                                       self.state_times[-1], self.magnitude, "time")
        return control_interpolant(self.grid, self.node_controls, self.s0, self.sf,
                                   self.magnitude, "anomaly")
