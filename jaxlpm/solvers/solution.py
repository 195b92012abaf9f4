"""Solution pytrees: `Solution` (the LQ laws, LGL), `TransferSolution` (Newton-KKT, any grid
and model) and `MinimumTimeSolution` (augmented Lagrangian): nodal values, cost, multipliers,
health."""

from dataclasses import dataclass, field

import jax

from ..orbits import th_to_lvlh, true_anomaly_from_time
from ..status import Status


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class Solution:
    """Optimal transfer at the collocation nodes, evaluable at any time by interpolation.

    node_f        chief true anomaly at the nodes (rad, continuous)
    node_times    time since the start of the transfer (s)
    node_states   LVLH states [x, y, z, vx, vy, vz] (m, m/s; x radial, y along-track, z normal)
    node_states_th Tschauner-Hempel states [x~, y~, z~, x~', y~', z~'] (m, m/rad)
    node_controls LVLH control acceleration u (m/s^2)
    cost          1/2 int |u|^2 dt (m^2/s^3), by the grid's quadrature
    cost_true_anomaly  1/2 int |u|^2/(1 + e cos f)^2 df = k^2 * cost (m^2/s^4; Mei 2010 eq. 5/8)
    costates      costate estimates p(f_i) of the TH formulation with cost
                  1/2 int |U|^2/rho^2 df, U = u/k^4 (m): U = -rho^2 B^T p
    multipliers   the law's own multipliers: STM law: terminal-constraint multiplier nu (6,)
                  (p(f_T) = nu); KKT law: multipliers gamma of the collocation equations (n, 6)
                  (Mei 2010 eq. 15-16 scaling)
    constraint_residual   max |defect| of the law's constraints (m, TH units)
    stationarity_residual max |dL/d(variables)| of the law's optimality conditions
    rcond         reciprocal condition number estimate of the system solved
    status        `Status` code (int32)
    """

    problem: object
    grid: object
    node_f: jax.Array
    node_times: jax.Array
    node_states: jax.Array
    node_states_th: jax.Array
    node_controls: jax.Array
    cost: jax.Array
    cost_true_anomaly: jax.Array
    costates: jax.Array
    multipliers: jax.Array
    constraint_residual: jax.Array
    stationarity_residual: jax.Array
    rcond: jax.Array
    status: jax.Array
    method: str = field(default="", metadata=dict(static=True))

    @property
    def message(self) -> str:
        """The status in words (concrete, unbatched solutions)."""
        return Status(int(self.status)).message

    def anomaly_interval(self):
        """(f0, fT): the true-anomaly interval the nodes span."""
        return self.node_f[..., 0], self.node_f[..., -1]

    def _tau(self, f):
        f0, fT = self.node_f[0], self.node_f[-1]
        return 2.0 * (f - f0) / (fT - f0) - 1.0

    def controls_at_true_anomaly(self, f):
        """u (m/s^2, LVLH) at chief true anomaly f: barycentric Lagrange over the nodes in f."""
        return self.grid.interpolate_control(self.node_controls, self._tau(f))

    def states_at_true_anomaly(self, f):
        """LVLH state at chief true anomaly f, interpolating the TH state polynomial."""
        o = self.problem.orbit
        x_th = self.grid.interpolate_state(self.node_states_th, self._tau(f))
        return th_to_lvlh(x_th, f, o.e, o.k2)

    def _f_of_t(self, t):
        return true_anomaly_from_time(self.problem.orbit, t)

    def controls(self, t):
        """u (m/s^2, LVLH) at time t (s since the transfer's start); vmap for many times."""
        return self.controls_at_true_anomaly(self._f_of_t(t))

    def states(self, t):
        """LVLH state (m, m/s) at time t (s since the transfer's start)."""
        return self.states_at_true_anomaly(self._f_of_t(t))


class _CollocatedSolution:
    """Status message and interpolation in the anomaly s shared by the Newton-KKT and
    augmented-Lagrangian solutions (fields s0, sf, grid, node_controls, state_times, states)."""

    @property
    def message(self) -> str:
        """The status in words (concrete, unbatched solutions)."""
        return Status(int(self.status)).message

    def anomaly_interval(self):
        """(s0, sf): the anomaly interval the nodes span."""
        return self.s0, self.sf

    def _tau(self, s):
        return 2.0 * (s - self.s0) / (self.sf - self.s0) - 1.0

    def controls_at_anomaly(self, s):
        """u (m/s^2, LVLH) at anomaly s: barycentric Lagrange over the collocation points."""
        return self.grid.interpolate_control(self.node_controls, self._tau(s))

    def _support(self, values):
        return values[:-1] if self.grid.scheme == "LG" else values

    def time_at_anomaly(self, s):
        """Time since the start (s) at anomaly s: Lagrange interpolation of the nodal times."""
        return self.grid.interpolate_state(self._support(self.state_times), self._tau(s))

    def states_at_anomaly(self, s):
        """LVLH state (m, m/s) at anomaly s: Lagrange interpolation of the nodal LVLH states
        over the state polynomial's support (for the "linear" model, whose polynomial is the
        TH state, this differs from it at the discretisation's accuracy)."""
        return self.grid.interpolate_state(self._support(self.states), self._tau(s))


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class TransferSolution(_CollocatedSolution):
    """A transfer solved by the Newton-KKT solver on any grid (LGL, LG, LGR) and model.

    s0, sf        the chief's anomaly at the start and end (rad): true anomaly for the
                  "linear" and "two-body" models, regularised anomaly int |h|/r^2 dt for "j2"
    node_s, node_times, node_controls   at the collocation points: anomaly (rad), time since
                  the start (s), LVLH control acceleration u (m/s^2)
    state_s, state_times, states        at the state rows (see `jaxlpm.nlp.transcription`):
                  anomaly, time, LVLH state (m, m/s; x radial, y along-track, z normal)
    cost          1/2 int |u|^2 dt (m^2/s^3), by the grid's quadrature
    cost_true_anomaly  k^2 * cost (m^2/s^4; Mei 2010 eq. 8's normalisation, k^2 = sqrt(mu/p^3))
    costates      costate estimates at the collocation points, in the solver's scaled units
                  (`jaxlpm.problems.relative`), per radian of anomaly
    multipliers   multipliers of the equality constraints (defects, then boundary)
    constraint_residual, stationarity_residual   max |c|, max |grad L| (scaled units)
    iterations    Newton iterations; history: KKT residual per iteration (zeros after)
    status        `Status` code (int32)
    """

    problem: object
    grid: object
    s0: jax.Array
    sf: jax.Array
    node_s: jax.Array
    node_times: jax.Array
    node_controls: jax.Array
    state_s: jax.Array
    state_times: jax.Array
    states: jax.Array
    cost: jax.Array
    cost_true_anomaly: jax.Array
    costates: jax.Array
    multipliers: jax.Array
    constraint_residual: jax.Array
    stationarity_residual: jax.Array
    iterations: jax.Array
    history: jax.Array
    status: jax.Array
    method: str = field(default="newton", metadata=dict(static=True))


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class MinimumTimeSolution(_CollocatedSolution):
    """A minimum-time transfer (`jaxlpm.problems.min_time`) solved by the augmented-Lagrangian
    solver on any grid. s is the circular chief's true anomaly, s = s0 + n t.

    duration      minimum transfer time t_f (s)
    node_s, node_times, node_controls   at the collocation points: anomaly (rad), time since
                  the start (s), LVLH thrust acceleration (T/m) u_hat (m/s^2)
    state_s, state_times, states        at the state rows: anomaly, time, LVLH state (m, m/s)
    costates      costate estimates at the collocation points (scaled units, per radian)
    multipliers   equality multipliers; path_multipliers: `PathPenalty` (direction, bounds)
    constraint_residual, path_residual, stationarity_residual, complementarity (scaled units)
    outer_iterations, inner_iterations, history (path violation per outer iteration), status
    """

    problem: object
    grid: object
    duration: jax.Array
    s0: jax.Array
    sf: jax.Array
    node_s: jax.Array
    node_times: jax.Array
    node_controls: jax.Array
    state_s: jax.Array
    state_times: jax.Array
    states: jax.Array
    costates: jax.Array
    multipliers: jax.Array
    path_multipliers: object
    constraint_residual: jax.Array
    path_residual: jax.Array
    stationarity_residual: jax.Array
    complementarity: jax.Array
    outer_iterations: jax.Array
    inner_iterations: jax.Array
    history: jax.Array
    status: jax.Array
    method: str = field(default="augmented-lagrangian", metadata=dict(static=True))

    @property
    def node_directions(self):
        """Thrust direction u_hat at the collocation points (LVLH unit vectors)."""
        return self.node_controls / self.problem.acceleration

    def _s_of_t(self, t):
        return self.s0 + self.problem.orbit.mean_motion * t

    def controls_at_time(self, t):
        """Thrust acceleration (m/s^2, LVLH) at time t (s since the start), interpolated."""
        return self.controls_at_anomaly(self._s_of_t(t))

    def states_at_time(self, t):
        """LVLH state (m, m/s) at time t (s since the start), interpolated."""
        return self.states_at_anomaly(self._s_of_t(t))
