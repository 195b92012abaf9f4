"""Design under uncertainty: choose mission parameters theta so that a risk measure of the
per-member cost over a dispersion of problems is least, by an optax optimiser on implicit
gradients of batched solves.

    minimise_theta  R( q(solve(P_1(theta))), ..., q(solve(P_n(theta))) )
                    lower <= theta <= upper   (projection after every step; a periodic
                                              leaf, an angle, wraps around instead)

theta: any pytree of float arrays (a duration in chief periods, a departure true anomaly,
waypoint states...). The dispersion (key, theta) -> one batched problem (every array leaf with
the members on its leading axis, as `jaxlpm.batch.problem_table` takes) says how theta and the
random draws make the problems; q is a per-member quantity of the `Solution` ("delta_v" m/s,
"cost" in the family's unit, or a function); R a risk measure (`jaxlpm.design.risk`: mean,
mean + k std, CVaR) over the SUCCESS members only (the others are left out of the statistic
and counted per status in the history).

The gradient: dR/dtheta = sum_i dR/dq_i (dq_i/dP_i) dP_i/dtheta, with dq_i/dP_i the implicit
gradient of member i's solve (the KKT law's linear solve, or the Newton-KKT solution by the
implicit function theorem, `jaxlpm.implicit`) and dP_i/dtheta the dispersion's own vjp. A
member that did not end SUCCESS gets a zero weight and a zero cotangent (masked explicitly, so
its NaNs never reach the gradient).

Each step draws the batch with key_k = fold_in(key, k) (common_random_numbers=True: the same
key at every step, i.e. the same samples: a deterministic objective for checks), solves it
batched in one compiled program, and warm-starts each Newton-KKT member from its own solution
at the step before (SI node states and controls mapped to the new problem's scaling; a member
that failed there starts from the linear model's KKT guess). The closed-form laws ("kkt",
"stm") and the other families start from their own guesses.

A run with `out` writes, after every step, `out/state.npz` (theta, the optimiser's state, the
warm starts, the history: what a resume needs, written atomically) and `out/history.json`
(the same history, readable); `optimise` with the same `out` and the same definition resumes
after the last finished step and gives the same iterates as an uninterrupted run.
"""

import functools
import json
import time
import weakref
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

import jax
import jax.numpy as jnp
import numpy as np
from tqdm import tqdm

from ..batch.store import _canonical, save_npz_atomic, write_json_atomic
from ..mapping import map_in_groups
from ..nlp.newton import NewtonOptions
from ..nlp.transcription import state_s, state_tau
from ..problems import EnergyOptimalTransfer
from ..problems.energy_optimal import control_scale, model_state, transfer_ocp
from ..solution import DEFAULT_TOLERANCE, judge
from ..solvers import solve
from ..solvers.api import FAMILIES
from ..solvers.transfer import linear_warm_start, newton_transfer
from ..status import Status
from .risk import MeanStd

if TYPE_CHECKING:
    import optax

QUANTITIES = {"delta_v": lambda sol: sol.delta_v, "cost": lambda sol: sol.cost}


@dataclass(frozen=True, eq=False)
class DesignProblem:
    """What to optimise (module docstring).

    dispersion  (key, theta) -> one batched problem of any family (members on the leading
                axis of every array leaf); traced, so jnp and jax.random only
    lower, upper  bounds on theta: pytrees of theta's structure (or scalars), SI or whatever
                unit theta is in
    risk        a risk measure (x (n,), w (n,)) -> scalar (`jaxlpm.design.risk`; default
                mean + 2 std)
    quantity    "delta_v" (int |u| dt, m/s; default), "cost" (the family's objective) or a
                function Solution -> scalar
    grid, method, options, tolerance   as `jaxlpm.solve` takes them (grid None: the
                family's default grid; no mesh refinement inside the design loop)
    width       members vmapped together (1: one at a time, `jaxlpm.batch.map_in_groups`)
    periodic    names of theta's leaves that wrap around their bounds instead of stopping at
                them (an angle on [0, 2 pi): the departure true anomaly), as `history` names
                them ("f0", or "a.b" for nested leaves)
    label       free text naming the dispersion and the optimiser: part of the definition a
                resumed run must match (functions cannot be compared)
    Compared and hashed by identity: its compiled step is kept with the object.
    """

    dispersion: Callable
    lower: Any
    upper: Any
    risk: Callable = MeanStd(2.0)
    quantity: Any = "delta_v"
    grid: Any = None
    method: str | None = None
    options: Any = None
    tolerance: Any = None
    width: int = 1
    periodic: tuple = ()
    label: str = ""

    def definition(self, theta0, key, common_random_numbers) -> dict:
        """The JSON-able facts a resumed run must share with the run it resumes."""
        describe = getattr(self.risk, "describe", None)
        return _canonical(dict(
            label=self.label, theta0=_named(theta0), lower=_named(_bound(self.lower, theta0)),
            upper=_named(_bound(self.upper, theta0)), key=np.asarray(jax.random.key_data(key)),
            common_random_numbers=bool(common_random_numbers),
            risk=describe() if describe else repr(self.risk),
            quantity=self.quantity if isinstance(self.quantity, str) else repr(self.quantity),
            grid=_describe_grid(self.grid), method=self.method, options=repr(self.options),
            tolerance=repr(self.tolerance), width=self.width, periodic=list(self.periodic)))


@dataclass
class DesignResult:
    """The optimiser's run. theta: the last iterate (after the last update); history: one
    dict per step (step, theta {name: value}, objective, gradient {name: value}, grad_norm,
    members, success, failed {status name: count}, seconds); out: the run's folder or None;
    stopped: why the run ended before `steps` (a step where no member ended SUCCESS has no
    statistic to follow: theta is then that step's iterate), else None."""

    theta: Any
    history: list = field(default_factory=list)
    out: Path | None = None
    stopped: str | None = None

    @property
    def solves(self) -> int:
        """Member solves made (each with its implicit gradient)."""
        return int(sum(h["members"] for h in self.history))



def _describe_grid(grid):
    """A grid as JSON-able facts: scheme and points, and a mesh's segments and breaks."""
    if grid is None:
        return None
    if hasattr(grid, "segment"):
        return dict(scheme=grid.scheme, segment_points=grid.segment.n,
                    breaks=np.asarray(grid.breaks).tolist())
    return dict(scheme=grid.scheme, points=grid.n)


def _named(tree) -> dict:
    leaves, _ = jax.tree_util.tree_flatten_with_path(tree)
    return {jax.tree_util.keystr(path, simple=True, separator="."): np.asarray(v).tolist()
            for path, v in leaves}


def _bound(bound, theta):
    """A bound as a pytree of theta's structure (a scalar bound broadcast to every leaf)."""
    if np.ndim(bound) == 0 and not isinstance(bound, (dict, list, tuple)):
        return jax.tree_util.tree_map(
            lambda t: jnp.full(jnp.shape(t), bound, jnp.float64), theta)
    return jax.tree_util.tree_map(lambda b: jnp.asarray(b, jnp.float64), bound)


def _periodic_mask(names, theta):
    """A pytree of theta's structure: True on the leaves named in `names`."""
    leaves, treedef = jax.tree_util.tree_flatten_with_path(theta)
    keys = [jax.tree_util.keystr(path, simple=True, separator=".") for path, _ in leaves]
    unknown = set(names) - set(keys)
    if unknown:
        raise ValueError(f"periodic names {sorted(unknown)} are not leaves of theta {keys}")
    return jax.tree_util.tree_unflatten(treedef, [k in names for k in keys])


def _project(theta, lower, upper, periodic):
    """Onto the box [lower, upper]; a periodic leaf wraps into [lower, upper) instead."""
    def one(t, lo, hi, wrap):
        return lo + jnp.mod(t - lo, hi - lo) if wrap else jnp.clip(t, lo, hi)
    return jax.tree_util.tree_map(one, theta, lower, upper, periodic)


def design_grid(design: DesignProblem, problem):
    """The grid the design's members are solved on: its own, or the family's default for
    one member `problem`."""
    if design.grid is not None:
        return design.grid
    return FAMILIES[type(problem)].default_grid(problem)


def _warm_starts_newton(problem, design, grid) -> bool:
    if not isinstance(problem, EnergyOptimalTransfer):
        return False
    method = design.method or FAMILIES[type(problem)].default_method(problem, grid)
    return method == "newton"


def _newton_guess(problem, grid, states, controls, usable):
    """z0 for `problem` from SI node states and controls of a solution of a neighbouring
    problem (mapped node by node to this problem's scaling and anomaly), or the linear
    model's KKT guess where `usable` is False."""
    problem = problem.sanitized(problem.validity())
    ocp = transfer_ocp(problem, grid)[0]
    X = jax.vmap(lambda x, s: model_state(problem, x, s))(states, state_s(ocp, grid))
    z = jnp.concatenate([X.reshape(-1), (controls / control_scale(problem)).reshape(-1)])
    z_linear = linear_warm_start(*jax.lax.stop_gradient((problem, ocp)), grid)[0]
    usable = usable & jnp.all(jnp.isfinite(z))
    return jax.lax.stop_gradient(jnp.where(usable, z, z_linear))


def _step_function(design: DesignProblem, newton: bool, grid):
    """jit of one step: (theta, key, carry) -> (objective, dR/dtheta, per-member quantity,
    status, next carry)."""
    tolerance = DEFAULT_TOLERANCE if design.tolerance is None else design.tolerance
    quantity = (QUANTITIES[design.quantity] if isinstance(design.quantity, str)
                else design.quantity)
    options = design.options if design.options is not None or not newton else NewtonOptions()

    def solve_one(problem, carry):
        if newton:
            z0 = _newton_guess(problem, grid, carry["states"], carry["controls"], carry["ok"])
            return judge(newton_transfer(problem, grid, options, z0=z0), tolerance)
        return solve(problem, grid, method=design.method, options=design.options,
                     tolerance=tolerance, throw=False)

    def member(args):
        problem, carry = args

        def value(prob):
            sol = solve_one(prob, carry)
            nxt = (dict(states=sol.node_states, controls=sol.node_controls,
                        ok=sol.status == Status.SUCCESS) if newton else carry)
            return quantity(sol), (sol.status, nxt)

        (q, (status, nxt)), g = jax.value_and_grad(value, has_aux=True)(problem)
        return q, status, g, nxt

    def step(theta, key, carry):
        problems, pullback = jax.vjp(lambda th: design.dispersion(key, th), theta)
        q, status, g, new_carry = map_in_groups(member, (problems, carry), design.width)
        good = (status == Status.SUCCESS) & jnp.isfinite(q)
        objective, dR_dq = jax.value_and_grad(design.risk)(jnp.where(good, q, 0.0),
                                                           good.astype(q.dtype))
        # no SUCCESS member: no statistic (NaN, recorded) and no step (zero gradient)
        objective = jnp.where(jnp.any(good), objective, jnp.nan)
        weight = jnp.where(good, dR_dq, 0.0)
        cotangent = jax.tree_util.tree_map(
            lambda leaf: jnp.where(good.reshape((-1,) + (1,) * (leaf.ndim - 1)),
                                   weight.reshape((-1,) + (1,) * (leaf.ndim - 1)) * leaf, 0.0),
            g)
        (gradient,) = pullback(cotangent)
        return objective, gradient, q, status, new_carry

    return jax.jit(step)


_STEPS = weakref.WeakKeyDictionary()


@dataclass(frozen=True)
class _Setup:
    """What a design's step needs besides theta: its grid, whether Newton-KKT members are
    warm-started, the member count, the compiled step."""

    grid: Any
    newton: bool
    members: int
    step: Callable

    def first_carry(self):
        """The warm starts of step 0: SI node states and controls (zeros) marked unusable."""
        n = self.members
        if not self.newton:
            return dict(states=jnp.zeros((n, 1)), controls=jnp.zeros((n, 1)),
                        ok=jnp.zeros(n, bool))
        rows = state_tau(self.grid).shape[0]
        return dict(states=jnp.zeros((n, rows, 6)), controls=jnp.zeros((n, self.grid.n, 3)),
                    ok=jnp.zeros(n, bool))


def _setup(design: DesignProblem, theta, key) -> _Setup:
    """The design's family, grid and member count from the dispersion's output shapes
    (jax.eval_shape: nothing solved), and its step compiled once per design object."""
    if design in _STEPS:
        return _STEPS[design]
    probe = jax.eval_shape(lambda: design.dispersion(key, theta))
    family = FAMILIES.get(type(probe))
    if family is None:
        raise ValueError(f"the dispersion must return a batched problem of a jaxlpm family, "
                         f"got {type(probe).__name__}")
    one = jax.tree_util.tree_map(lambda s: jnp.zeros(s.shape[1:], s.dtype), probe)
    grid = design_grid(design, one)
    newton = _warm_starts_newton(one, design, grid)
    members = jax.tree_util.tree_leaves(probe)[0].shape[0]
    _STEPS[design] = _Setup(grid, newton, members, _step_function(design, newton, grid))
    return _STEPS[design]


def evaluate(design: DesignProblem, theta, key) -> dict:
    """One batch at theta with the samples of `key`: objective (design.risk of the
    SUCCESS members' quantity), gradient (d objective / d theta, theta's structure), quantity
    and status per member (the statistic and its implicit gradient an `optimise` step
    takes, without warm starts)."""
    theta = jax.tree_util.tree_map(lambda v: jnp.asarray(v, jnp.float64), theta)
    setup = _setup(design, theta, key)
    objective, gradient, q, status, _ = setup.step(theta, key, setup.first_carry())
    return dict(objective=objective, gradient=gradient, quantity=q, status=status)


def _load(out: Path, definition, theta0, opt_state0, carry0):
    path = out / "state.npz"
    if not path.exists():
        return None
    with np.load(path) as data:
        saved = json.loads(str(data["definition"]))
        if saved != definition:
            diff = sorted(k for k in set(saved) | set(definition)
                          if saved.get(k) != definition.get(k))
            raise ValueError(f"{out} holds a design run of another definition (differs in "
                             f"{diff}); give another folder or the same settings")
        restore = lambda prefix, like: jax.tree_util.tree_unflatten(  # noqa: E731
            jax.tree_util.tree_structure(like),
            [jnp.asarray(data[f"{prefix}{k}"]) for k in range(len(jax.tree_util.tree_leaves(like)))])
        return (restore("theta", theta0), restore("opt", opt_state0),
                restore("carry", carry0), json.loads(str(data["history"])))


def _save(out: Path, definition, theta, opt_state, carry, history):
    arrays = {f"theta{k}": np.asarray(v) for k, v in enumerate(jax.tree_util.tree_leaves(theta))}
    arrays |= {f"opt{k}": np.asarray(v)
               for k, v in enumerate(jax.tree_util.tree_leaves(opt_state))}
    arrays |= {f"carry{k}": np.asarray(v)
               for k, v in enumerate(jax.tree_util.tree_leaves(carry))}
    save_npz_atomic(out / "state.npz", definition=np.array(json.dumps(definition)),
                    history=np.array(json.dumps(history)), **arrays)
    write_json_atomic(out / "history.json", dict(definition=definition, history=history))


def optimise(design: DesignProblem, theta0, key, *, steps: int = 30,
             optimizer: "optax.GradientTransformation | None" = None,
             common_random_numbers: bool = False, out=None, progress: bool = True,
             log=None) -> DesignResult:
    """Minimise design.risk of the per-member quantity over theta (module docstring) by
    `steps` steps of `optimizer` (default optax.adam(0.05): its steps are about the learning
    rate in every coordinate, so give theta coordinates of a similar scale), each followed by
    the projection onto [lower, upper]. out: a folder to save and resume the run (module
    docstring). log(str): one line per step (tqdm shows the same when progress=True)."""
    import optax         # here: 0.1 s of every `import jaxlpm` otherwise (issue 21)

    optimizer = optax.adam(0.05) if optimizer is None else optimizer
    theta0 = jax.tree_util.tree_map(lambda v: jnp.asarray(v, jnp.float64), theta0)
    lower, upper = _bound(design.lower, theta0), _bound(design.upper, theta0)
    project = jax.jit(functools.partial(_project, lower=lower, upper=upper,
                                        periodic=_periodic_mask(design.periodic, theta0)))
    theta = project(theta0)
    setup = _setup(design, theta, key)
    n, carry = setup.members, setup.first_carry()
    opt_state = optimizer.init(theta)
    definition = design.definition(theta0, key, common_random_numbers)
    history, start, stopped = [], 0, None
    if out is not None:
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        loaded = _load(out, definition, theta, opt_state, carry)
        if loaded is not None:
            theta, opt_state, carry, history = loaded
            start = len(history)
    update = jax.jit(lambda g, s, th: optimizer.update(g, s, th))
    bar = tqdm(range(start, steps), desc="design", unit="step", disable=not progress,
               initial=start, total=steps)
    for k in bar:
        t0 = time.perf_counter()
        key_k = key if common_random_numbers else jax.random.fold_in(key, k)
        objective, gradient, q, status, carry = setup.step(theta, key_k, carry)
        status = np.asarray(status)
        counts = {Status(int(s)).name: int((status == s).sum()) for s in np.unique(status)
                  if s != Status.SUCCESS}
        grad_norm = float(optax.tree.norm(gradient))
        record = dict(step=k, theta=_named(theta), objective=float(objective),
                      gradient=_named(gradient), grad_norm=grad_norm, members=n,
                      success=int((status == Status.SUCCESS).sum()), failed=counts,
                      seconds=time.perf_counter() - t0)
        history.append(_canonical(record))
        if not record["success"]:
            stopped = (f"step {k}: no member ended SUCCESS ({counts}) at theta "
                       f"{record['theta']}: a finer grid or narrower bounds")
            break
        updates, opt_state = update(gradient, opt_state, theta)
        theta = project(optax.apply_updates(theta, updates))
        if out is not None:
            _save(out, definition, theta, opt_state, carry, history)
        bar.set_postfix(objective=f"{record['objective']:.6g}", grad=f"{grad_norm:.3g}",
                        success=f"{record['success']}/{n}")
        if log is not None:
            log(f"step {k}: objective {record['objective']:.6g}, |grad| {grad_norm:.3g}, "
                f"{record['success']}/{n} SUCCESS, theta {record['theta']}")
    bar.close()
    if stopped is not None and log is not None:
        log("stopped at " + stopped)
    return DesignResult(theta=theta, history=history, out=out, stopped=stopped)
