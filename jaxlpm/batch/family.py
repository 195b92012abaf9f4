"""What a sweep solves: a `SweepFamily` (how to build one problem from one member's
parameters, the solve settings, what to record), the default record taken from the
`Solution` itself, and the families built on it: a batch of problems given as one batched
pytree (`problem_table`, Monte Carlo draws), energy-optimal transfers about a base case
(`transfer_family`), and any family with derivatives added (`sensitivity_family`).

Node counts are points: a family's `grid` builds its grid from a number of points
(`lgl(65)` is Mei 2010's degree N = 64).
"""

import dataclasses
from dataclasses import dataclass, field
from typing import Any, Callable

import jax
import jax.numpy as jnp
import numpy as np

from ..collocation import lgl
from ..problems import EnergyOptimalTransfer
from ..problems.energy_optimal import perigee_above_surface
from ..solvers import solve

TRANSFER_PARAMETERS = ("e", "a", "i", "raan", "argp", "f0", "revolutions", "duration", "x0",
                       "xf")
HOLDS = ("perigee", "a")
TRANSFER_METHODS = {"kkt": "linear", "stm": "linear", "newton": "two-body"}
PROBLEM_PREFIX = "problem."          # the columns of a batched problem's leaves


def solve_member(problem, grid, method, options):
    """`jaxlpm.solve(problem, grid, method=method, options=options, throw=False)`: one
    member's `Solution`, its failure a status (a sweep counts failures, it never raises)."""
    return solve(problem, grid, method=method, options=options, throw=False)


def solution_record(solution) -> dict:
    """What a sweep stores per member by default, all from the `Solution` (SI): status
    (int32 `Status`), cost (the family's objective: m^2/s^3 energy-optimal, s minimum time,
    m/s fuel-optimal), delta_v (int |u| dt, m/s), duration (s), and every scalar of
    `solution.stats` under its own name (iterations, residuals, the paper's cost
    normalisation...; each family's docstring lists its stats). Arrays and nested stats
    (histories, multipliers) are left out: record them with a record of your own."""
    out = dict(status=solution.status, cost=solution.cost, delta_v=solution.delta_v,
               duration=solution.duration)
    for name, value in solution.stats.items():
        if isinstance(value, (jax.Array, np.ndarray)) and value.ndim == 0 and name not in out:
            out[name] = value
    return out


def _jsonable(options):
    """Solver options as JSON-able settings (frozen dataclasses as dicts)."""
    if dataclasses.is_dataclass(options):
        return dict(type=type(options).__name__, **dataclasses.asdict(options))
    return options


@dataclass(frozen=True)
class SweepFamily:
    """A problem family as `sweep` solves it, member by member:

        record(solver(build(member parameters), grid(points), method, options))

    name        short name, recorded in the manifest
    build       (one member's parameters: dict of arrays) -> problem pytree; traced (under
                lax.map/vmap), so jnp only
    grid        points -> grid: `lgl` (default), `lg`, `lgr`, or e.g.
                `lambda n: segmented_lgr(uniform_breaks(0.0, 1.0, 24), n)` (n points per segment)
    method, options   passed to `jaxlpm.solve` (None: the family's default)
    record      `Solution` -> dict of arrays, one member's row; it must hold an integer
                "status" (`Status`; SUCCESS = 0). Default `solution_record`
    definition  JSON-able facts that determine the results beyond the method and options
                (what is held fixed, conventions, the grid and record when they are not the
                defaults); two sweeps with different definitions never share a directory
    validate    optional host check of the parameter table (ValueError on bad input)
    cpu_batch_size  the vmap width `sweep` uses on the CPU backend when the caller gives none
                (None: all of a device's members of the chunk). 1 (default) for solvers built
                on LAPACK factorisations: on CPU a vmapped LAPACK call runs member by member
                anyway, and jaxlib 0.10's batched kernels deadlock when two devices run them at
                once (the KKT law's sweep on 2 CPU devices hung at N = 64; experiments/README.md)
    solver      (problem, grid, method, options) -> what `record` takes; default
                `solve_member` (`jaxlpm.solve`, not raising). Not part of the definition: a
                wrapper that only observes (counts traces, logs) resumes the same sweep
    """

    name: str
    build: Callable
    grid: Callable = lgl
    method: str | None = None
    options: Any = None
    record: Callable = solution_record
    definition: dict = field(default_factory=dict)
    validate: Callable | None = None
    cpu_batch_size: int | None = 1
    solver: Callable = solve_member

    def evaluate(self, member: dict, grid) -> dict:
        """One member's record on `grid` (traced)."""
        return self.record(self.solver(self.build(member), grid, self.method, self.options))

    def settings(self) -> dict:
        """The family's part of a sweep's definition: `definition`, the method and options."""
        return dict(self.definition, method=self.method, options=_jsonable(self.options))


# ------------------------------------------------------------------------------------------
# a batch of problems given as one batched pytree


def problem_table(problems) -> tuple[dict, Callable]:
    """A batched problem (any family: one pytree whose every array leaf has the members on its
    leading axis, e.g. `jax.vmap(make_problem)(keys)`) as a sweep's parameter table and
    builder: (params, build) with params {"problem.<leaf path>": NumPy array (n, ...)}
    ("problem.orbit.e", "problem.x0", ...) and build(member) -> that member's problem.
    Scalar (0-d) leaves are shared by every member and broadcast; any other leaf without the
    common leading axis is a ValueError naming it."""
    leaves, treedef = jax.tree_util.tree_flatten_with_path(problems)
    names = [PROBLEM_PREFIX + jax.tree_util.keystr(path, simple=True, separator=".")
             for path, _ in leaves]
    arrays = [np.asarray(leaf) for _, leaf in leaves]
    sizes = {a.shape[0] for a in arrays if a.ndim}
    if len(sizes) != 1:
        shapes = {name: a.shape for name, a in zip(names, arrays)}
        raise ValueError(f"a batched {type(problems).__name__} needs the members on the leading "
                         f"axis of every array leaf (one common size); got shapes {shapes}")
    n = sizes.pop()
    params = {name: np.broadcast_to(a, (n,)) if a.ndim == 0 else a
              for name, a in zip(names, arrays)}

    def build(member):
        return jax.tree_util.tree_unflatten(treedef, [member[name] for name in names])

    return params, build


# ------------------------------------------------------------------------------------------
# energy-optimal transfers about a base case


def transfer_builder(base: EnergyOptimalTransfer, hold: str = "perigee") -> Callable:
    """Build an `EnergyOptimalTransfer` from `base` with a member's parameters replacing its
    leaves: orbit elements (e, a, i, raan, argp, f0; SI, rad), the duration as `revolutions`
    (chief periods of the member's orbit) or `duration` (s), and x0, xf (LVLH, m, m/s).

    A member with e but no a holds the chief's perigee radius r_p = a (1 - e) of `base`
    (hold="perigee": a = r_p / (1 - e)) or its semi-major axis (hold="a"). A member with
    neither revolutions nor duration keeps `base`'s duration in revolutions.
    """
    if hold not in HOLDS:
        raise ValueError(f"hold must be one of {HOLDS}, got {hold!r}")
    o = base.orbit
    r_p = o.a * (1.0 - o.e)
    revolutions = base.duration / o.period

    def build(p):
        elements = {k: p[k] for k in ("e", "a", "i", "raan", "argp", "f0") if k in p}
        if "e" in p and "a" not in p and hold == "perigee":
            elements["a"] = r_p / (1.0 - p["e"])
        orbit = o.replace(**elements)
        duration = p["duration"] if "duration" in p else (
            p.get("revolutions", revolutions) * orbit.period)
        return base.replace(orbit=orbit, duration=duration, x0=p.get("x0", base.x0),
                            xf=p.get("xf", base.xf))

    return build


def _check_transfer_parameters(base, hold):
    def validate(params):
        unknown = sorted(set(params) - set(TRANSFER_PARAMETERS))
        if unknown:
            raise ValueError(f"unknown transfer parameters {unknown}; allowed: "
                             f"{list(TRANSFER_PARAMETERS)}")
        if "revolutions" in params and "duration" in params:
            raise ValueError("give the duration as 'revolutions' or as 'duration', not both")
        for name in ("x0", "xf"):
            if name in params and params[name].shape[1:] != (6,):
                raise ValueError(f"{name} must have shape (members, 6), got {params[name].shape}")
        e = params.get("e", np.asarray(base.orbit.e))
        if np.any(e < 0.0) or np.any(e >= 1.0):
            raise ValueError(f"e must be in [0, 1) (elliptic chief), got values in "
                             f"[{e.min()}, {e.max()}]")
        a = params.get("a")
        if a is None:
            o = base.orbit
            a = (np.asarray(o.a * (1.0 - o.e)) / (1.0 - e) if hold == "perigee"
                 else np.full_like(e, float(o.a)))
        if base.model != "linear" and not np.all(perigee_above_surface(a, e, float(base.r_eq))):
            raise ValueError(f"the {base.model!r} model needs the chief's perigee radius "
                             f"a (1 - e) above r_eq = {float(base.r_eq)} m (hold={hold!r}); got "
                             f"a minimum of {np.min(a * (1.0 - e))} m; lower e or hold the "
                             f"perigee radius")
        for name in ("revolutions", "duration"):
            if name in params and not np.all(params[name] > 0.0):
                raise ValueError(f"{name} must be positive, got a minimum of "
                                 f"{params[name].min()}")

    return validate


def transfer_record(solution) -> dict:
    """`solution_record` less the duration, which a transfer sweep's parameters fix (its
    `duration`, or `revolutions` x the member's period)."""
    record = solution_record(solution)
    del record["duration"]
    return record


def transfer_family(name: str, base: EnergyOptimalTransfer, method: str = "kkt",
                    hold: str = "perigee") -> SweepFamily:
    """Energy-optimal transfers about `base` (see `transfer_builder` for the parameters),
    solved by `method` on grid lgl(points): "kkt" or "stm" (Mei 2010's linear laws, linear
    model) or "newton" (Newton-KKT on the nonlinear two-body model). Records
    `transfer_record`: status, cost (m^2/s^3), delta_v (m/s) and the method's scalar stats
    (cost_true_anomaly (m^2/s^4), constraint and stationarity residuals, rcond or
    iterations)."""
    if method not in TRANSFER_METHODS:
        raise ValueError(f"method must be one of {sorted(TRANSFER_METHODS)}, got {method!r}")
    base = base.replace(model=TRANSFER_METHODS[method])
    o = base.orbit
    definition = dict(
        problem="EnergyOptimalTransfer", model=base.model, grid="lgl(points)",
        record="transfer_record",
        held_when_e_varies=("perigee radius r_p = a (1 - e) of the base orbit" if hold == "perigee"
                            else "semi-major axis a of the base orbit"),
        base=dict(a=float(o.a), e=float(o.e), r_p=float(o.a * (1.0 - o.e)), i=float(o.i),
                  raan=float(o.raan), argp=float(o.argp), f0=float(o.f0), mu=float(o.mu),
                  revolutions=float(base.duration / o.period), duration=float(base.duration),
                  x0=np.asarray(base.x0).tolist(), xf=np.asarray(base.xf).tolist(),
                  thrust_axes=list(base.thrust_axes)))
    # the STM law is LAPACK-free in its batched form (and much faster vmapped)
    return SweepFamily(name=name, build=transfer_builder(base, hold), grid=lgl, method=method,
                       record=transfer_record, definition=definition,
                       validate=_check_transfer_parameters(base, hold),
                       cpu_batch_size=None if method == "stm" else 1)


# ------------------------------------------------------------------------------------------
# derivatives


def sensitivity_family(family: SweepFamily, wrt=None, control_gain: bool = True) -> SweepFamily:
    """`family` with derivatives added to its record (any family solved into a `Solution`):

      initial_control  (3,) u(t = 0) (m/s^2, LVLH), the interpolated control at the start
      d<out>_d<p>      d cost / d p and d delta_v / d p for each member parameter p in `wrt`
                       (default: every floating-point parameter of the table), through the
                       family's builder, so its conventions hold (e with the perigee radius
                       held, say); an array parameter (x0, xf) gives an array of partials
      control_gain     (3, 6) d u(0) / d x0, where the family's problem has an x0: the initial
                       optimal control's Jacobian with respect to the initial LVLH state, the
                       neighbouring-optimal feedback gain (1/s^2, 1/s)

    Derivatives of a solution are those of its solver: for the LQ laws autodiff through their
    linear solve (the implicit-function theorem for a linear KKT system), for the Newton-KKT
    and augmented-Lagrangian solvers the implicit function theorem at the KKT point
    (`jaxlpm.implicit`). Reverse mode (`jax.jacrev`): one adjoint solve per output (cost,
    delta_v, the 3 components of u(0)); the library's implicit derivatives (Kepler's
    equation, the KKT point) are custom_vjp rules, which forward mode cannot use.
    """
    def differentiated(p, grid, method, options):
        names = sorted(k for k in p if jnp.issubdtype(p[k].dtype, jnp.floating)) \
            if wrt is None else list(wrt)
        gain = control_gain and hasattr(family.build(p), "x0")

        def outputs(q, dx0):
            problem = family.build({**p, **q})
            if gain:
                problem = dataclasses.replace(problem, x0=problem.x0 + dx0)
            sol = family.solver(problem, grid, method, options)
            u0 = sol.trajectory.control(jnp.zeros_like(sol.duration))
            return dict(cost=sol.cost, delta_v=sol.delta_v, u0=u0), (family.record(sol), u0)

        jac, (rec, u0) = jax.jacrev(outputs, argnums=(0, 1), has_aux=True)(
            {k: p[k] for k in names}, jnp.zeros(6))
        rec = dict(rec, initial_control=u0)
        for out in ("cost", "delta_v"):
            for k in names:
                rec[f"d{out}_d{k}"] = jac[out][0][k]
        if gain:
            rec["control_gain"] = jac["u0"][1]
        return rec

    def validate(params):
        if family.validate is not None:
            family.validate(params)
        unknown = sorted(set(wrt or ()) - set(params))
        if unknown:
            raise ValueError(f"wrt names {unknown} are not parameters of the table "
                             f"{sorted(params)}")
        integer = sorted(k for k in (wrt or ()) if not np.issubdtype(params[k].dtype,
                                                                     np.floating))
        if integer:
            raise ValueError(f"wrt names {integer} are integer parameters: no derivative")

    definition = dict(family.definition, sensitivities=dict(
        wrt=None if wrt is None else list(wrt), control_gain=control_gain))
    # the gradients' tangent solves (implicit differentiation) are LAPACK calls
    return SweepFamily(name=family.name, build=lambda p: p, grid=family.grid,
                       method=family.method, options=family.options, record=dict,
                       definition=definition, validate=validate, cpu_batch_size=1,
                       solver=differentiated)
