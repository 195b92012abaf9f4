"""Batched mesh refinement of energy-optimal transfers (`jaxlpm.solvers.refine`): every member
is solved on the ladder's first rung; only the members that come out INACCURATE go on to the
next rung, each on its own breaks (split where its own error is, and where its safety
constraints are violated between the nodes: `refinement_error`) and warm-started from its own
previous solution. A rung's mesh shape is fixed, its breaks an array leaf, so each rung is one
compiled function whatever the members and breaks (`lax.map` over groups of `width` members).
"""

import functools

import jax
import jax.numpy as jnp
import numpy as np

from ..collocation.segments import LGRMesh, lgr_mesh
from ..collocation import lgr
from ..nlp.augmented_lagrangian import ALOptions
from ..nlp.newton import NewtonOptions
from ..problems.energy_optimal import scaled_rows
from ..solution import DEFAULT_TOLERANCE, judge
from ..solution.accuracy import refinement_error
from ..solvers.energy_optimal import rung_options
from ..solvers.refine import DEFAULT_LADDER, interpolated_guess, split_breaks
from ..solvers.transfer import newton_transfer
from ..status import Status
from .sweep import map_in_groups


def accuracy_record(solution):
    """A member's record: status, cost (m^2/s^3), the error estimate (m, m/s, relative),
    Newton iterations; with safety constraints their dense check too (constraint_violation,
    violation_position, violation_velocity, path_violation: `safety_stats`)."""
    st = solution.stats
    safety = {key: st[key] for key in ("constraint_violation", "violation_position",
                                       "violation_velocity", "path_violation") if key in st}
    return dict(status=solution.status, cost=solution.cost,
                error_position=st["error_position"], error_velocity=st["error_velocity"],
                relative_error=st["relative_error"], iterations=st["iterations"], **safety)


def gradient_record(gradient) -> dict:
    """{"dcost_d<leaf>": d cost / d leaf} for every leaf of a problem-shaped gradient
    (`jax.grad` of the cost): "dcost_dx0" (6,), "dcost_dduration", "dcost_dorbit.e", ... in
    the cost's SI unit (m^2/s^3) per the leaf's SI unit."""
    leaves, _ = jax.tree_util.tree_flatten_with_path(gradient)
    return {"dcost_d" + jax.tree_util.keystr(path).lstrip("."): value for path, value in leaves}


@functools.lru_cache(maxsize=None)
def _rung_function(shape, previous, options, tolerance, width, record, gradients):
    """jit(map over members) of one rung: (problems, breaks, carried previous solution) ->
    (records, carry for the next rung)."""
    k, n = shape

    def solve(problem, breaks, prev):
        mesh = LGRMesh(breaks, lgr(n))
        if previous is None:
            sol = newton_transfer(problem, mesh, options)
        else:
            X, U = interpolated_guess(prev["X"], prev["U"],
                                      LGRMesh(prev["breaks"], lgr(previous[1])), mesh)
            sol = newton_transfer(problem, mesh, options,
                                  z0=jnp.concatenate([X.reshape(-1), U.reshape(-1)]))
        return sol.cost, judge(sol, tolerance)

    def member(args):
        problem, breaks, prev = args
        if gradients:     # the implicit gradient on this rung's mesh: one adjoint KKT solve
            (_, sol), grad = jax.value_and_grad(solve, has_aux=True)(problem, breaks, prev)
            extra = gradient_record(grad)
        else:
            sol, extra = solve(problem, breaks, prev)[1], {}
        X, U = scaled_rows(sol)
        return record(sol) | extra, dict(breaks=breaks, X=X, U=U,
                                         error=refinement_error(sol.stats, tolerance))

    return jax.jit(lambda ps, bs, prev: map_in_groups(member, (ps, bs, prev), width))


def _take(tree, idx):
    return jax.tree_util.tree_map(lambda x: x[idx], tree)


def refine_batch(problems, *, ladder=DEFAULT_LADDER, tolerance=DEFAULT_TOLERANCE,
                 options: NewtonOptions | ALOptions | None = None, record=accuracy_record,
                 gradients: bool = False, width: int = 1, log=None) -> dict:
    """Refine a batch of `EnergyOptimalTransfer`s (leading axis: members) rung by rung (module
    docstring). record(solution) -> dict of arrays: what is kept of each member's final
    solution (the default: `accuracy_record`; it may fly the solution, `jaxlpm.verify.fly`).
    gradients: also the implicit gradient of the cost with respect to every leaf of the
    problem (`gradient_record`: dcost_dx0, dcost_dxf, dcost_dduration, dcost_dorbit.e, ...),
    taken on each member's final mesh (its breaks held fixed). options: the solver's (None:
    `NewtonOptions()`, or `ALOptions()` for transfers with safety constraints). Returns the
    records as NumPy arrays (members first) plus "rung" (the rung each member ended on) and
    "segments" (its mesh's segment count)."""
    if options is None:
        options = ALOptions() if problems.constraints else NewtonOptions()
    n_members = jax.tree_util.tree_leaves(problems)[0].shape[0]
    todo = np.arange(n_members)
    out, carry, previous = None, None, None
    for index, shape in enumerate(ladder.rungs):
        k, _ = shape
        if previous is None:
            breaks = np.tile(np.asarray(lgr_mesh(k, 2).breaks), (todo.size, 1))
        else:
            breaks = np.stack([split_breaks(b, e, k) for b, e in
                               zip(np.asarray(carry["breaks"]),
                                   np.asarray(carry["error"]))])
        fn = _rung_function(shape, previous, rung_options(options, k), tolerance, width, record,
                            gradients)
        recs, new_carry = fn(_take(problems, todo), jnp.asarray(breaks),
                             carry if carry is not None else jnp.zeros(todo.size))
        recs = {key: np.asarray(v) for key, v in recs.items()}
        if out is None:
            out = {key: np.zeros((n_members,) + v.shape[1:], v.dtype) for key, v in recs.items()}
            out["rung"] = np.zeros(n_members, np.int32)
            out["segments"] = np.zeros(n_members, np.int32)
        for key, v in recs.items():
            out[key][todo] = v
        out["rung"][todo], out["segments"][todo] = index, k
        again = recs["status"] == Status.INACCURATE
        if log is not None:
            log(f"rung {index} ({k} x {shape[1]}): {todo.size} members, "
                f"{int(again.sum())} still INACCURATE")
        todo = todo[again]
        if not todo.size:
            break
        carry = _take(jax.tree_util.tree_map(np.asarray, new_carry), np.flatnonzero(again))
        previous = shape
    return out
