"""`Solution`: the one result type of every transfer family, a frozen pytree.

Every family returns a `Solution` with the same fields and methods, in SI: times in s since
the start of the transfer (t0 = 0), states and controls in the family's `frame` (LVLH for the
relative transfers: x radial outward, y along-track, z orbit normal; m, m/s, m/s^2). How the
states, controls and costates are evaluated between the nodes is the `trajectory`'s job
(`jaxlpm.solution.collocated` and the other trajectory modules); what a solver reports beside
them (iterations, residuals, multipliers, histories, a paper's cost normalisation) is in
`stats`, a dict whose keys each family documents.
"""

from dataclasses import dataclass, field, replace
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from .._validation import is_concrete
from ..compilation import compiled
from ..constants import G0
from ..status import Status

# evaluation times may exceed [0, duration] by this fraction of the duration (round-off in a
# caller's own grid of times), no more
TIME_SLACK = 1e-9

# the intercept families' failures in words, by (method, status)
_INTERCEPT_DETAILS = {
    ("shooting", Status.INFEASIBLE): (
        "infeasible Lambert seed: no allowed revolution count and branch reaches r_target in "
        "the time after the burn (stats['lambert_status'])"),
    ("shooting", Status.SINGULAR): (
        "singular Lambert seed: the transfer angle from the burn point to r_target is 0 or pi "
        "(the transfer plane is undefined; stats['lambert_status'])"),
    ("augmented-lagrangian", Status.INFEASIBLE): (
        "infeasible: the engine is too weak for the intercept (the burn that eq. (2) centres "
        "on the impulse does not fit between 0 and t_f), no burn within max_duration reaches "
        "r_target, or the impulsive seed has no Lambert solution (stats['seed_status'])"),
}


class SolveError(RuntimeError):
    """An unbatched `jaxlpm.solve(..., throw=True)` that did not end SUCCESS. `status` is the
    `Status`, `solution` the full result (what `throw=False` returns)."""

    def __init__(self, solution):
        self.solution = solution
        self.status = Status(int(solution.status))
        super().__init__(f"{self.status.name}: {solution.message}")


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class Solution:
    """A solved transfer, evaluable at any time t in [0, duration] (s since the start).

    problem     the problem solved (for invalid traced input: a harmless stand-in)
    status      `Status` code (int32; one per member when batched); `success`, `message`,
                `messages`
    cost        the family's objective in SI: energy-optimal 1/2 int |u|^2 dt (m^2/s^3),
                minimum time t_f (s), fuel-optimal int |u| dt (m/s), ...
    duration    the transfer time (s)
    trajectory  the evaluation of states, controls and costates between the nodes
    stats       solver-specific numbers (each family's docstring lists them)
    method      the method that solved it (static)
    frame       the frame of states and controls (static): "LVLH" or "inertial"

    Node values: `times` (collocation points, s) with `node_controls`; `state_times` with
    `node_states`; `grid` (a `Grid` or `SegmentedMesh`). Under vmap every array carries the
    batch axes in front; evaluate a batched solution member by member
    (`jax.vmap(lambda s: s.states(t))(sol)`).
    """

    problem: Any
    status: jax.Array
    cost: jax.Array
    duration: jax.Array
    trajectory: Any
    stats: dict
    method: str = field(default="", metadata=dict(static=True))
    frame: str = field(default="LVLH", metadata=dict(static=True))

    def replace(self, **kwargs) -> "Solution":
        return replace(self, **kwargs)

    # ---- health -------------------------------------------------------------------------

    @property
    def success(self):
        """status == SUCCESS (bool array, one per member when batched)."""
        return self.status == Status.SUCCESS

    @property
    def message(self) -> str:
        """The status in words; for a batch, how many members ended in each status."""
        st = np.asarray(self.status)
        if st.ndim:
            codes, counts = np.unique(st, return_counts=True)
            parts = [f"{c} {Status(int(k)).name}" for k, c in zip(codes, counts)]
            return f"{st.size} members: " + ", ".join(parts) + " (per member: .messages)"
        return self._detail(Status(int(st)), ())

    @property
    def messages(self) -> np.ndarray:
        """The status of every member in words (a NumPy array of str, the batch's shape)."""
        st = np.asarray(self.status)
        out = np.empty(st.shape, dtype=object)
        for idx in np.ndindex(st.shape):
            out[idx] = self._detail(Status(int(st[idx])), idx)
        return out

    def _detail(self, status, idx):
        if self.method == "homotopy" and status == Status.STALLED:
            eps = float(np.asarray(self.stats["eps"])[idx])
            return (f"homotopy stalled: eps could not be driven below {eps:.3g} (the "
                    f"continuation step fell below its minimum); the result is the "
                    f"eps = {eps:.3g} solution")
        if self.method == "homotopy" and status == Status.INFEASIBLE:
            return ("infeasible: the thrust bound cannot reach the target in the time (full "
                    "thrust everywhere, or the dual ascent diverged); stats['terminal_error'] "
                    "is the miss")
        if self.frame == "inertial" and (self.method, status) in _INTERCEPT_DETAILS:
            return _INTERCEPT_DETAILS[self.method, status]
        return status.message

    # ---- nodes --------------------------------------------------------------------------

    @property
    def grid(self):
        """The `Grid` (lgl/lg/lgr, n points) or `SegmentedMesh` the solution lives on."""
        return self.trajectory.grid

    @property
    def times(self):
        """Times of the collocation points (s since the start)."""
        return self.trajectory.times

    @property
    def node_controls(self):
        """Controls at `times` (m/s^2 in `frame`)."""
        return self.trajectory.node_controls

    @property
    def state_times(self):
        """Times of the state rows (s): the collocation points and, where the scheme does not
        collocate them, the ends."""
        return self.trajectory.state_times

    @property
    def node_states(self):
        """States at `state_times` (m, m/s in `frame`)."""
        return self.trajectory.node_states

    @property
    def t0(self):
        """Start time (s): 0, the origin of every time in the solution."""
        return jnp.zeros_like(self.duration)

    # ---- evaluation ---------------------------------------------------------------------

    def _checked_time(self, t):
        t = jnp.asarray(t, dtype=jnp.result_type(self.duration))
        if is_concrete(t, self.duration) and np.ndim(self.duration) == 0:
            tt, d = np.asarray(t), float(np.asarray(self.duration))
            if (not np.all(np.isfinite(tt)) or np.any(tt < -TIME_SLACK * d)
                    or np.any(tt > d * (1.0 + TIME_SLACK))):
                raise ValueError(f"t must lie in [0, duration] = [0, {d:.6g}] s (time since "
                                 f"the start of the transfer), got {tt}")
        return t

    def evaluable(self) -> "Solution":
        """This solution with only what evaluating it reads, its trajectory and duration (the
        problem, stats and method left out): the programs that evaluate it (`_evaluated`,
        `jaxlpm.verify.fly`'s plan) then serve every solution of one trajectory kind and
        size, whatever problem and stats it came with."""
        return replace(self, problem=None, stats={}, method="")

    def _evaluate(self, which, t):
        """The trajectory's `which` ("state", "control", "costate") at t in [0, duration],
        mapped over t of any shape; NaN outside [0, duration] (traced t; a concrete t outside
        raises ValueError). Concrete input runs one compiled program (`_evaluated`), not
        the interpolation op by op."""
        return _evaluated(self.evaluable(), self._checked_time(t), which)

    def states(self, t):
        """States (m, m/s in `frame`) at times t (s since the start; any shape, the state
        axis last): the transcription's state polynomial (or the family's exact flow)."""
        return self._evaluate("state", t)

    def controls(self, t):
        """Controls (m/s^2 in `frame`) at times t (s since the start; any shape)."""
        return self._evaluate("control", t)

    def costates(self, t):
        """Costates at times t (s since the start): the sensitivity dJ*/dx of the optimal
        cost to the state at t, in the cost's SI unit per m and per m/s (each family says
        how it estimates them)."""
        return self._evaluate("costate", t)

    # ---- derived quantities ------------------------------------------------------------

    @property
    def delta_v(self):
        """int |u| dt (m/s) over the transfer (impulses: the sum of |dv|)."""
        return self.trajectory.delta_v()

    def propellant(self, m0, isp):
        """Propellant mass (kg) for `delta_v` by the rocket equation m0 (1 - exp(-dv /
        (isp g0))): m0 the initial mass (kg), isp the specific impulse (s)."""
        return m0 * -jnp.expm1(-self.delta_v / (isp * G0))


@compiled(static_argnames="which")
def _evaluated(solution, t, which):
    """`Solution._evaluate`: the trajectory's method `which` at every t (any shape)."""
    evaluate = getattr(solution.trajectory, which)
    slack = TIME_SLACK * solution.duration

    def one(ti):
        inside = (ti >= -slack) & (ti <= solution.duration + slack)
        value = evaluate(jnp.clip(ti, 0.0, solution.duration))
        return jnp.where(inside, value, jnp.nan)

    flat = jax.vmap(one)(t.reshape(-1))
    return flat.reshape(t.shape + flat.shape[1:])


def zero_invalid(valid, tree):
    """Every array leaf of tree where valid, zeros elsewhere (invalid traced input)."""
    return jax.tree_util.tree_map(lambda x: jnp.where(valid, x, jnp.zeros_like(x)), tree)
