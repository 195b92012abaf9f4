"""Batched mesh refinement (`jaxlpm.solvers.refine`) of energy-optimal, fuel-optimal,
minimum-time and LQR transfers: every member is solved on the ladder's first rung; only the
members that come out INACCURATE go on to the next rung, each on its own breaks, and, where the
family warm-starts, from its own previous solution. A rung's mesh shape is fixed, its breaks an
array leaf, and every rung runs over all the batch's rows, the members already done skipped by
a `lax.cond` (`masked`), so each rung is one compiled function whatever the members and breaks
(`lax.map` over groups of `width` members). The sweep engine's "refine" group
(`jaxlpm.batch.sweep`) climbs each chunk the same way (`climb`).

Where each family puts the next rung's breaks, as its single solve does (`solve(problem)`
without a grid):
  energy-optimal   split where the member's own error is, and where its safety constraints
                   are violated between the nodes (`refinement_error`); warm-started from the
                   previous solution's polynomial (`EnergyPlan`)
  fuel-optimal     a break at each of the member's switching times (`aligned_breaks`: the
                   switches move with the mesh, so the default ladder repeats each segment
                   count); each rung runs the energy-to-fuel homotopy afresh (`FuelPlan`)
  minimum time     method "condensed" (every model): uniform meshes; method
                   "augmented-lagrangian" (HCW, and LGL ladders on the linear and two-body
                   models): split by the error, each rung from its own minimum-time guess
                   (`MinTimePlan`)
  LQR              the Riccati sweep's uniform steps doubled, 512 to 4096 (rungs (steps, 1);
                   no breaks, no warm start: `LQRPlan`)
"""

import dataclasses
import functools
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from ..collocation.segments import MESHES, SegmentedMesh, uniform_breaks
from ..nlp.augmented_lagrangian import ALOptions
from ..nlp.homotopy import HomotopyOptions
from ..nlp.newton import NewtonOptions
from ..problems import EnergyOptimalTransfer, LQRTransfer, MinimumTimeTransfer
from ..problems.fuel_optimal import FuelOptimalTransfer
from ..problems.energy_optimal import scaled_rows
from ..solution import DEFAULT_TOLERANCE, Tolerance, judge
from ..solution.accuracy import refinement_error
from ..solvers import fuel_optimal, lqr, min_time, min_time_condensed
from ..solvers.energy_optimal import rung_options
from ..solvers.fuel_constrained import FuelALOptions
from ..solvers.min_time_condensed import CondensedOptions
from ..solvers.refine import DEFAULT_LADDER, MeshLadder, interpolated_guess, split_breaks
from ..solvers.transfer import newton_transfer
from ..status import Status
from ..mapping import map_in_groups

_RECORD_KEYS = ("iterations", "newton_iterations", "fuel", "constraint_violation",
                "violation_position", "violation_velocity", "path_violation")


def accuracy_record(solution):
    """A member's record: status, cost (the family's SI unit: m^2/s^3 energy, m/s delta-v,
    s duration), duration (s), the error estimate (m, m/s, relative), and those of
    iterations (Newton-KKT), newton_iterations (the fuel homotopy's), fuel (kg) and the
    dense check of safety constraints (constraint_violation, violation_position,
    violation_velocity, path_violation: `safety_stats`) that its stats carry."""
    st = solution.stats
    return dict(status=solution.status, cost=solution.cost, duration=solution.duration,
                error_position=st["error_position"], error_velocity=st["error_velocity"],
                relative_error=st["relative_error"],
                **{key: st[key] for key in _RECORD_KEYS if key in st})


def gradient_record(gradient) -> dict:
    """{"dcost_d<leaf>": d cost / d leaf} for every leaf of a problem-shaped gradient
    (`jax.grad` of the cost): "dcost_dx0" (6,), "dcost_dduration", "dcost_dorbit.e", ... in
    the cost's SI unit per the leaf's SI unit."""
    leaves, _ = jax.tree_util.tree_flatten_with_path(gradient)
    return {"dcost_d" + jax.tree_util.keystr(path).lstrip("."): value for path, value in leaves}


@dataclass(frozen=True)
class EnergyPlan:
    """Energy-optimal transfers: Newton-KKT (or the augmented Lagrangian with safety
    constraints) on the ladder's meshes (`LGRMesh`; `LGMesh`, `LGLMesh` by its scheme),
    split by `refinement_error`, warm-started."""

    ladder: MeshLadder = DEFAULT_LADDER
    options: NewtonOptions | ALOptions = NewtonOptions()
    warm_start = True

    @property
    def method(self):
        return "augmented-lagrangian" if isinstance(self.options, ALOptions) else "newton"

    def rung_options(self, shape):
        return rung_options(self.options, shape[0])

    def first_breaks(self, k):
        return uniform_breaks(-1.0, 1.0, k)

    def next_breaks(self, carry, shape, previous):
        return split_breaks(carry["breaks"], carry["error"], shape[0])

    def _mesh(self, breaks, n):
        """The ladder's scheme's mesh (traced breaks: no host checks)."""
        cls, grid = MESHES[self.ladder.scheme]
        return cls(breaks, grid(n))

    def solve(self, problem, breaks, prev, shape, previous, options):
        mesh = self._mesh(breaks, shape[1])
        if previous is None:
            return newton_transfer(problem, mesh, options)
        X, U = interpolated_guess(prev["X"], prev["U"], self._mesh(prev["breaks"], previous[1]),
                                  mesh)
        return newton_transfer(problem, mesh, options,
                               z0=jnp.concatenate([X.reshape(-1), U.reshape(-1)]))

    def carry(self, solution, breaks, tolerance):
        X, U = scaled_rows(solution)
        return dict(breaks=breaks, X=X, U=U, error=refinement_error(solution.stats, tolerance))


def fuel_ladder(ladder, passes=fuel_optimal.ALIGN_PASSES):
    """The fuel family's single refinement on `ladder` as one rung a mesh: its first rung
    uniform, then `passes` aligned meshes of each rung's shape."""
    return MeshLadder(ladder.rungs[:1] + tuple(r for r in ladder.rungs for _ in range(passes)),
                      ladder.scheme)


@dataclass(frozen=True)
class FuelPlan:
    """Fuel-optimal transfers: the homotopy (`HomotopyOptions`) or the augmented Lagrangian
    (`FuelALOptions`: with safety constraints, on LGL segments) on `SegmentedMesh` rungs
    (breaks as fractions of the transfer), the first uniform, each next one with a break at
    every switching time of the member's previous solution (`aligned_breaks`)."""

    ladder: MeshLadder = fuel_ladder(fuel_optimal.LADDER)
    options: HomotopyOptions | FuelALOptions = HomotopyOptions()
    warm_start = False

    @property
    def method(self):
        return "augmented-lagrangian" if isinstance(self.options, FuelALOptions) else "homotopy"

    def rung_options(self, shape):
        return self.options

    def first_breaks(self, k):
        return np.asarray(uniform_breaks(0.0, 1.0, k))

    def next_breaks(self, carry, shape, previous):
        return fuel_optimal.next_breaks(carry["breaks"], self._grid(previous[1]).weights,
                                        carry["throttle"], carry["threshold"], *shape,
                                        self.ladder.scheme, self.method)

    def solve(self, problem, breaks, prev, shape, previous, options):
        return fuel_optimal.run(problem, SegmentedMesh(breaks, self._grid(shape[1])),
                                self.method, options)

    def _grid(self, n):
        return MESHES[self.ladder.scheme][1](n)

    def carry(self, solution, breaks, tolerance):
        st = solution.stats
        return dict(breaks=breaks, throttle=st["node_throttle"],
                    threshold=jnp.asarray(st.get("burn_threshold", fuel_optimal.BURNING)))


@dataclass(frozen=True)
class MinTimePlan:
    """Minimum-time transfers: method "condensed" on uniform `SegmentedMesh` rungs, or method
    "augmented-lagrangian" (HCW, and LGL ladders) on the ladder's meshes split by the error; no
    warm start (each rung's own minimum-time guess carries the duration and the primer)."""

    ladder: MeshLadder
    options: CondensedOptions | ALOptions
    clock: str = "hcw"          # the augmented Lagrangian's (`min_time.run`), from the batch
    warm_start = False

    @property
    def condensed(self):
        return isinstance(self.options, CondensedOptions)

    @property
    def method(self):
        return "condensed" if self.condensed else "augmented-lagrangian"

    def rung_options(self, shape):
        return self.options

    def first_breaks(self, k):
        return uniform_breaks(0.0 if self.condensed else -1.0, 1.0, k)

    def next_breaks(self, carry, shape, previous):
        if self.condensed:
            return self.first_breaks(shape[0])
        return split_breaks(carry["breaks"], carry["error"], shape[0])

    def solve(self, problem, breaks, prev, shape, previous, options):
        cls, grid = MESHES[self.ladder.scheme]
        mesh = (SegmentedMesh if self.condensed else cls)(breaks, grid(shape[1]))
        return min_time.run(problem, mesh, self.method, options, self.clock)

    def carry(self, solution, breaks, tolerance):
        return dict(breaks=breaks, error=refinement_error(solution.stats, tolerance))


@dataclass(frozen=True)
class LQRPlan:
    """LQR transfers: the Riccati sweep on rungs of (steps, 1), the uniform steps doubled as
    its single solve doubles them (`lqr.refine_steps`; each step a segment whose flow is
    exact, so no breaks to place and nothing to warm-start)."""

    ladder: MeshLadder = MeshLadder(tuple((steps, 1) for steps in lqr.REFINE_STEPS))
    options: None = None
    warm_start = False
    method = "riccati"

    def rung_options(self, shape):
        return None

    def first_breaks(self, k):
        return np.zeros(0)

    def next_breaks(self, carry, shape, previous):
        return np.zeros(0)

    def solve(self, problem, breaks, prev, shape, previous, options):
        return lqr.run(problem, shape[0], self.method, options)

    def carry(self, solution, breaks, tolerance):
        return {}


def refinement_plan(problems, ladder=None, options=None):
    """The plan (`EnergyPlan`, `FuelPlan`, `MinTimePlan`, `LQRPlan`) of a batch of
    `problems`, with the family's default ladder and options where they are None. Ladders of
    LGR, LG and LGL meshes for energy-optimal transfers and HCW minimum time by the augmented
    Lagrangian; LGR and LG segments for the fuel-optimal homotopy and method "condensed",
    LGL ones too for fuel-optimal transfers by the augmented Lagrangian (the default on an LGL
    ladder; ValueError otherwise: `fuel_optimal.check_ladder`)."""
    if isinstance(problems, EnergyOptimalTransfer):
        if options is None:
            options = ALOptions() if problems.constraints else NewtonOptions()
        return EnergyPlan(DEFAULT_LADDER if ladder is None else ladder, options)
    if isinstance(problems, FuelOptimalTransfer):
        if ladder is None:
            ladder = (fuel_ladder(fuel_optimal.CONSTRAINED_LADDER) if problems.constraints
                      else FuelPlan.ladder)
        if options is None:
            options = (FuelALOptions() if fuel_optimal.default_method(problems, ladder)
                       == "augmented-lagrangian" else HomotopyOptions())
        fuel_optimal.check_ladder(ladder, condensed=isinstance(options, HomotopyOptions))
        return FuelPlan(ladder, options)
    if isinstance(problems, MinimumTimeTransfer):
        if options is None:
            options = min_time.default_options(min_time.refine_method(problems, ladder), ladder)
        if ladder is None:
            ladder = (min_time.LADDER if isinstance(options, ALOptions)
                      else min_time_condensed.LADDER)
        if isinstance(options, CondensedOptions):
            fuel_optimal.check_ladder(ladder)
        return MinTimePlan(ladder, options,
                           "hcw" if min_time.hcw_clock(problems) else "anomaly")
    if isinstance(problems, LQRTransfer):
        if options is not None:
            raise ValueError(f"the Riccati sweep takes no options, got {options!r:.60}")
        return LQRPlan() if ladder is None else LQRPlan(ladder)
    raise ValueError(f"refine_batch refines EnergyOptimalTransfer, FuelOptimalTransfer, "
                     f"MinimumTimeTransfer and LQRTransfer batches, got "
                     f"{type(problems).__name__}")


@dataclass(frozen=True)
class Refinement:
    """How a batch refines (`refine_batch`, and a sweep's "refine" group: `jaxlpm.batch.sweep`):
    ladder (None: the family's, `refinement_plan`), tolerance (`jaxlpm.Tolerance`, SI) and
    gradients (also the implicit gradient of the cost with respect to every leaf of the
    problem, on each member's final mesh: `gradient_record`; every family but minimum time by
    method "condensed")."""

    ladder: MeshLadder | None = None
    tolerance: Tolerance = DEFAULT_TOLERANCE
    gradients: bool = False

    def settings(self) -> dict:
        """JSON-able (a sweep's definition)."""
        return dict(ladder=None if self.ladder is None else [list(r) for r in self.ladder.rungs],
                    tolerance=dataclasses.asdict(self.tolerance), gradients=self.gradients)


def rung_member(plan, shape, previous, refinement, record, build=None):
    """One member on one rung: (member, breaks, carried previous solution) -> (its record,
    what the next rung needs of it); member is a problem, or with `build` the parameters
    build(member) makes it from (a sweep's row)."""
    options = plan.rung_options(shape)
    previous = previous if plan.warm_start else None

    def solve(problem, breaks, prev):
        sol = judge(plan.solve(problem, breaks, prev, shape, previous, options),
                    refinement.tolerance)
        return sol.cost, sol

    def member(args):
        problem, breaks, prev = args
        if build is not None:
            problem = build(problem)
        if refinement.gradients:     # the implicit gradient on this rung's mesh: one adjoint solve
            (_, sol), grad = jax.value_and_grad(solve, has_aux=True)(problem, breaks, prev)
            extra = gradient_record(grad)
        else:
            sol, extra = solve(problem, breaks, prev)[1], {}
        return record(sol) | extra, plan.carry(sol, breaks, refinement.tolerance)

    return member


def masked(member):
    """member on the rows where `active`, zeros of its outputs' shapes elsewhere: a
    `lax.cond`, so an inactive row costs nothing where members run one at a time (lax.map
    width 1; under a wider vmap the cond becomes a select and the row is solved anyway).
    Every rung then has one fixed shape, the batch's (or a sweep chunk's) rows."""
    def run(args):
        xs, active = args
        shapes = jax.eval_shape(member, xs)
        return jax.lax.cond(active, member, lambda _: jax.tree_util.tree_map(
            lambda s: jnp.zeros(s.shape, s.dtype), shapes), xs)
    return run


@functools.lru_cache(maxsize=None)
def _rung_function(plan, shape, previous, refinement, width, record):
    """jit(map over the batch's rows) of one rung: (problems, breaks, carried previous
    solution, active) -> (records, carry for the next rung)."""
    member = masked(rung_member(plan, shape, previous, refinement, record))
    return jax.jit(lambda ps, bs, prev, active: map_in_groups(
        member, ((ps, bs, prev), active), width))


def _take(tree, idx):
    return jax.tree_util.tree_map(lambda x: x[idx], tree)


def climb(plan, rows: int, active, run_rung, log=None) -> dict:
    """The ladder for a batch of `rows` members of which `active` (bool (rows,)) are solved:
    run_rung(index, shape, previous, breaks, carry, active) -> (records, carry) runs one rung on
    all rows (carry None on the first; jnp.zeros(rows) stands for it where the plan does not
    warm-start), solving the active ones. Returns the records as NumPy arrays of the active
    members' final rungs (zeros elsewhere) plus "rung" and "segments"."""
    todo = np.asarray(active, bool).copy()
    out, carry, previous = None, None, None
    for index, shape in enumerate(plan.ladder.rungs):
        k = shape[0]
        breaks = np.tile(plan.first_breaks(k), (rows, 1))
        if carry is not None:
            for i in np.flatnonzero(todo):
                breaks[i] = plan.next_breaks(_take(carry, i), shape, previous)
        recs, carry = run_rung(index, shape, previous, jnp.asarray(breaks),
                               carry if carry is not None and plan.warm_start
                               else jnp.zeros(rows), jnp.asarray(todo))
        recs = {key: np.asarray(v) for key, v in recs.items()}
        if out is None:
            out = {key: np.zeros((rows,) + v.shape[1:], v.dtype) for key, v in recs.items()}
            out["rung"] = np.zeros(rows, np.int32)
            out["segments"] = np.zeros(rows, np.int32)
        for key, v in recs.items():
            out[key][todo] = v[todo]
        out["rung"][todo], out["segments"][todo] = index, k
        again = todo & (recs["status"] == Status.INACCURATE)
        if log is not None:
            log(f"rung {index} ({k} x {shape[1]}): {int(todo.sum())} members, "
                f"{int(again.sum())} still INACCURATE")
        todo = again
        if not todo.any():
            break
        carry = jax.tree_util.tree_map(np.asarray, carry)
        previous = shape
    return out


def _member_rows(problems, n):
    """The batch with a leading member axis on every leaf: a leaf of one member's shape (a
    default shared by every member, such as j2 or duration_bounds) broadcast to n rows."""
    return jax.tree_util.tree_map(
        lambda x, one: jnp.broadcast_to(x, (n,) + np.shape(one))
        if np.ndim(x) == np.ndim(one) else x, problems, problems.harmless())


def check_refinement(plan, refinement: Refinement):
    """ValueError for a refinement the plan cannot do."""
    if refinement.gradients and isinstance(plan, MinTimePlan) and plan.condensed:
        raise ValueError("gradients=True: a minimum-time solve by method 'condensed' is not "
                         "differentiated (its costates give dt_f/dx0 and dt_f/dxf; the "
                         "augmented Lagrangian, on HCW and on LGL ladders, is)")


def refine_batch(problems, *, ladder: MeshLadder | None = None, tolerance=DEFAULT_TOLERANCE,
                 options=None, record=accuracy_record, gradients: bool = False, width: int = 1,
                 log=None) -> dict:
    """Refine a batch of `EnergyOptimalTransfer`s, `FuelOptimalTransfer`s,
    `MinimumTimeTransfer`s or `LQRTransfer`s (leading axis: members) rung by rung (module
    docstring).

    ladder: the rungs' mesh shapes (None: the family's, as its single solve climbs them:
    `DEFAULT_LADDER`; the fuel family's 24 x 8 uniform, then 3 aligned passes each of 24, 48 and
    96 segments of 8 points (LG), with safety constraints 16 x 8 uniform, then 3 aligned passes
    each of 16 and 24 segments (LGR); minimum time's `min_time.LADDER` on HCW, else 16, 32, 64
    and 128 x 8; LQR 512 to 4096 steps as (steps, 1)). options: the solver's (None: the
    family's default). record(solution) -> dict of arrays: what is kept of each member's final
    solution (the default: `accuracy_record`; it may fly the solution, `jaxlpm.verify.fly`).
    gradients: also the implicit gradient of the cost with respect to every leaf of the problem
    (`gradient_record`: dcost_dx0, dcost_dduration, dcost_dorbit.e, ...), taken on each member's
    final mesh (its breaks held fixed); energy-optimal, fuel-optimal, LQR, and minimum time by
    the augmented Lagrangian (method "condensed" is not differentiated). Every rung runs on all
    members (one compiled function per rung for the batch's size), the members already done
    skipped by a `lax.cond` (`masked`). Returns
    the records as NumPy arrays (members first) plus "rung" (the rung each member ended on) and
    "segments" (its mesh's segment count)."""
    refinement = Refinement(ladder, tolerance, gradients)
    plan = refinement_plan(problems, ladder, options)
    check_refinement(plan, refinement)
    if np.ndim(problems.x0) != 2 or np.shape(problems.x0)[0] < 1:
        raise ValueError(f"problems must carry a leading member axis (x0 of shape (n, 6)), "
                         f"got x0 of shape {np.shape(problems.x0)}")
    n_members = np.shape(problems.x0)[0]
    problems = _member_rows(problems, n_members)

    def run_rung(index, shape, previous, breaks, carry, active):
        fn = _rung_function(plan, shape, previous if plan.warm_start else None, refinement,
                            width, record)
        return fn(problems, breaks, carry, active)

    return climb(plan, n_members, np.ones(n_members, bool), run_rung, log)
