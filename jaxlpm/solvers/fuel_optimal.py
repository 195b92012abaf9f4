"""Fuel-optimal bounded-thrust transfers (`jaxlpm.problems.fuel_optimal`) on the linear
(Tschauner-Hempel, HCW at e = 0), two-body and J2 models by segmented LGR or LG collocation and
the energy-to-fuel homotopy (`jaxlpm.nlp.homotopy`), with mesh refinement at the switching times
(Yue & Duan 2016's pipeline: an energy-optimal Radau pseudospectral solution, then the
homotopy to the bang-bang fuel optimum).

`jaxlpm.solve(problem, mesh)` (`run`): one mesh (jit; vmap over problems and meshes of one
shape). `jaxlpm.solve(problem)`: mesh refinement to the accuracy tolerance
(`refine_transfer`; `solve(problem, MeshLadder(rungs, scheme="LG"))` on LG segments). With
safety constraints, on LGL segments (whose states the condensed transcription cannot
eliminate: an LGL segment collocates both its ends) or when asked (method
"augmented-lagrangian"), the same pipeline runs with the states kept
(`jaxlpm.solvers.fuel_constrained`).
`indirect_fuel_optimal(problem, breaks)`: the paper's indirect method on the linear model,
shooting on the costates with the smoothed switching law, continued in eps from the LGR
costates. `refine_fuel_optimal(problems, segments, points)`: host-side passes over
meshes with a break at every switching time of the previous solution (`aligned_breaks`), the
first mesh uniform, until the fuel changes by less than `fuel_tol` (relative); a batch of
problems is solved member by member (or in vmapped groups) each pass.

Nonlinear models (successive linearisation): the homotopy runs on the condensed problem
linearised about the collocated states of the previous run (the first about the chief itself,
x = 0: the linearised model), warm-started from its eps = 1 multipliers, until the states move
by at most `HomotopyOptions.linearisation_tol` (then the nonlinear collocation equations hold:
status SUCCESS) or `max_linearisations` runs (MAX_ITERATIONS). On the linear model one run is
exact.

Derivatives: the solution is differentiated by the implicit function theorem
(`jaxlpm.implicit.root`) on r(nu) = sum_i E_i v_i(nu) - d = 0 at the final eps, together with
the fixed point of the linearisation, X = X(nu; X), on the nonlinear models. The fuel is
differentiable where no collocation point sits inside the smoothed throttle's transition
(stats["partial_throttle"] = 0; its slope there is 1 / (2 eps)): a parameter change that
moves a switch across a collocation point changes the discrete switching structure, and the
derivative of the bang-bang fuel is that of the mesh's current structure.

Switching function: the primer vector p = -lambda_v / (n dt/ds) (`primer`). On the linear model
the costate obeys lambda' = -A(s)^T lambda exactly and the final-state multiplier nu gives
p(s) = -(k^2 / (n rho)) [Phi(s_f, s)^T nu]_v (Phi the Yamanaka-Ankersen STM, rho = 1 + e cos f;
on HCW p(s) = -B^T exp(A^T (s_f - s)) nu). At the collocation points the estimates
p_i = -E_i^T nu / c_i (the LGR costate estimates, Garg et al. 2010) agree with it to the mesh's
accuracy; on the nonlinear models `primer` interpolates them. The engine fires where |p| > 1;
`burn_arcs` and the switches that the refinement aligns the mesh with are read from the firing
collocation points (`_burn_runs`).
"""

import dataclasses
import functools
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from ..compilation import compiled, pipelined
from .._validation import is_concrete, require_x64
from ..collocation import interpolation_matrix, lg_nodes_weights
from ..collocation.segments import (CONDENSED_SCHEMES, MESHES, SEGMENTED_SCHEMES, SegmentedMesh,
                                   aligned_breaks, as_segmented, segmented_lgr, segmented_mesh,
                                   tau_mesh, uniform_breaks)
from ..dynamics import yamanaka_ankersen_stm
from ..dynamics.chief import kepler_final_anomaly
from ..implicit import root
from ..mapping import map_in_groups
from ..orbits import time_from_true_anomaly, true_anomaly_from_time
from ..problems.energy_optimal import control_scale, lvlh_state, model_state, transfer_chief
from ..problems.fuel_optimal import (FuelOptimalTransfer, check_fuel_problem, delta_v_unit,
                                     rocket_fuel, to_solution, transcribe)
from ..nlp.homotopy import HomotopyOptions, controls, energy_to_fuel, residual, run_homotopy
from ..solution import Solution
from ..status import Status
from .family import FamilySolver
from .fuel_constrained import FuelALOptions, constrained_fuel_optimal
from .refine import MeshLadder

MIN_POINTS = 3
BURNING = 1e-9             # a collocation point fires where its throttle exceeds this


def _input_gain(f, e):
    """B(f) of the solver's Tschauner-Hempel state: [0; I / rho^3]
    (`energy_optimal.th_dynamics`)."""
    return jnp.concatenate([jnp.zeros((3, 3)), jnp.eye(3) / (1.0 + e * jnp.cos(f)) ** 3])


def _exact_primer(sol, t):
    problem = sol.problem
    o = problem.orbit
    f = true_anomaly_from_time(o, t)
    phi = yamanaka_ankersen_stm(sol.trajectory.sf, f, problem.duration - t, o.e, o.k2)
    lam = phi.T @ sol.stats["multipliers"]
    return -(o.k2 / (o.mean_motion * (1.0 + o.e * jnp.cos(f)))) * lam[3:]


def primer(sol, t):
    """Primer vector p(t) (3,) of a fuel-optimal `Solution` (module docstring), t in s since
    the start: exact from the multipliers on the linear model, the interpolated collocation
    point estimates on the nonlinear ones."""
    if sol.problem.model == "linear":
        return _exact_primer(sol, t)
    tr = sol.trajectory
    return tr.grid.interpolate_control(sol.stats["node_primers"].reshape(-1, 3), tr.tau(t))


def switching_function(sol, t):
    """rho(t) = 1 - |p(t)| (Yue & Duan 2016 eq. 34): the engine fires where rho < 0."""
    return 1.0 - jnp.linalg.norm(primer(sol, t))


def _linearisations(tr, options: HomotopyOptions):
    """(nlp, homotopy result, reference, runs, last change): the homotopy on the condensed
    problem `nlp` linearised about the collocation states `reference` (K n, 6), relinearised
    about its solution until the states settle (module docstring). The result solves `nlp`
    itself: the homotopy's residual is ill-conditioned at a point inside the throttle's
    transition (slope 1 / (2 eps)), so it is not re-evaluated on a later linearisation. The
    first run, about zero states, is the loop's first pass (one homotopy in the program)."""
    def run_at(ref, nu0):
        nlp = tr.linearised(ref)
        res = run_homotopy(nlp.E, nlp.c, nlp.d, nu0, options)
        return nlp, res, nlp.cond.collocation_rows(nlp.states(res.nu, res.eps))

    ref = jnp.zeros((tr.mesh.n_points, 6), tr.ocp.params["x0"].dtype)
    nu0 = jnp.zeros_like(tr.ocp.params["x0"])
    if tr.problem.model == "linear":
        nlp, res, _ = run_at(ref, nu0)
        return nlp, res, ref, jnp.asarray(1), jnp.zeros((), ref.dtype)

    def going(state):
        _, res, _, _, k, change = state
        ok = (res.status == Status.SUCCESS) | (res.status == Status.STALLED)
        return (k == 0) | (ok & (k < options.max_linearisations)
                           & (change > options.linearisation_tol))

    def body(state):
        _, res, _, ref, k, _ = state
        nlp, res, X = run_at(ref, jnp.where(k == 0, nu0, res.nu_energy))
        return nlp, res, ref, X, k + 1, jnp.max(jnp.abs(X - ref))

    # the first pass's carry: zeros of run_at's outputs (never read: k == 0 starts from nu0)
    nlp0, res0, _ = jax.tree_util.tree_map(lambda a: jnp.zeros(a.shape, a.dtype),
                                           jax.eval_shape(run_at, ref, nu0))
    nlp, res, ref, _, runs, change = jax.lax.while_loop(
        going, body, (nlp0, res0, ref, ref, jnp.asarray(0), jnp.zeros((), ref.dtype)))
    return nlp, res, ref, runs, change


def _optimality(z, problem, mesh, eps):
    """F(z) = 0 at the solution: r(nu) on the final linearisation and, on the nonlinear
    models, the fixed point ref - X(nu; ref) of its reference states."""
    if problem.model == "linear":
        nlp = transcribe(problem, mesh).linearised(jnp.zeros((mesh.n_points, 6)))
        return residual(z, nlp.E, nlp.c, nlp.d, eps)
    nu, ref = z
    nlp = transcribe(problem, mesh).linearised(ref)
    return (residual(nu, nlp.E, nlp.c, nlp.d, eps),
            ref - nlp.cond.collocation_rows(nlp.states(nu, eps)))


@root(_optimality, zero_nonfinite=True)
def _differentiable(z, problem, mesh, eps):
    """The solved z, with derivatives by the implicit function theorem on `_optimality`."""
    return z


def fuel_solve(problem, mesh, options):
    """The solve's first stage: (the problem with invalid values replaced, whether it was
    valid, the homotopy's result with its status, the final linearisation's reference states,
    the chief (`transfer_chief`, on the J2 model: one integration for both stages; else
    None), the linearisation stats)."""
    valid = problem.validity()
    problem = problem.sanitized(valid)
    # the J2 chief integrated once for both stages; a Keplerian chief is analytic, computed
    # where it is used (shared, the linear model's solve took 10 % longer: 85 -> 95 ms on
    # yue2016's 24 x 8 mesh)
    chief = (transfer_chief(problem.energy_problem(), tau_mesh(mesh))
             if problem.model == "j2" else None)
    tr = transcribe(problem, mesh, chief)
    nlp, res, ref, runs, change = jax.lax.stop_gradient(_linearisations(tr, options))
    status = jnp.where(
        (problem.model != "linear") & (res.status == Status.SUCCESS)
        & (change > options.linearisation_tol), Status.MAX_ITERATIONS, res.status)
    status = jnp.where(valid & tr.ok, status, Status.INVALID_INPUT).astype(jnp.int32)
    if problem.model == "linear":
        nu = _differentiable(res.nu, problem, mesh, res.eps)
    else:
        nu, ref = _differentiable((res.nu, ref), problem, mesh, res.eps)
    res = dataclasses.replace(res, nu=nu, status=status)
    return problem, valid, res, ref, chief, dict(linearisations=runs,
                                                 linearisation_change=change)


def fuel_solution(problem, mesh, valid, res, ref, chief, extra) -> Solution:
    """The solve's last stage: the `Solution` of `fuel_solve`'s result."""
    tr = transcribe(problem, mesh, chief)
    return to_solution(tr, tr.linearised(ref), res, valid, extra=extra)


def _fuel_optimal_transfer(problem, mesh, options):
    problem, *solved = fuel_solve(problem, mesh, options)
    return fuel_solution(problem, mesh, *solved)


_solve_stage = compiled(fuel_solve, static_argnames="options")
_solution_stage = compiled(fuel_solution)


def _compiled(problem, mesh, options):
    """`_fuel_optimal_transfer` as its two stages, each compiled apart: the first solve of a
    signature compiles them side by side (`pipelined`)."""
    def run():
        problem_s, *solved = _solve_stage(problem, mesh, options)
        return _solution_stage(problem_s, mesh, *solved)

    return pipelined(run, _solve_stage, problem, mesh, options)


DEFAULT_SEGMENTS, DEFAULT_POINTS = 24, 8     # Yue & Duan 2016's mesh


def check_segmented(mesh, what: str, condensed: bool = True, hint: str = "") -> SegmentedMesh:
    """`as_segmented(mesh)` for the segmented families (`what` their name in the message): a
    ValueError unless it is a `SegmentedMesh` of at least `MIN_POINTS` points a segment, of
    LGR or LG segments where the transcription is `condensed` (`CONDENSED_SCHEMES`; `hint`
    ends that message)."""
    mesh = as_segmented(mesh)
    if not isinstance(mesh, SegmentedMesh):
        raise ValueError(f"the grid of {what} is a SegmentedMesh (segmented_lgr(breaks, n), "
                         f"segmented_lg(breaks, n) or segmented_lgl(breaks, n), breaks as "
                         f"fractions of [s0, s_f]) or a solution's LGRMesh, LGMesh or LGLMesh, "
                         f"got {type(mesh).__name__}")
    if condensed and mesh.grid.scheme not in CONDENSED_SCHEMES:
        raise ValueError(f"{what} takes LGR or LG segments (its condensed transcription "
                         f"eliminates the states segment by segment from its start, and an "
                         f"LGL segment collocates both its ends), got {mesh.grid.scheme} "
                         f"segments{hint}")
    if mesh.grid.n < MIN_POINTS:
        raise ValueError(f"the segments of {what} need at least {MIN_POINTS} "
                         f"{mesh.grid.scheme} points, got {mesh.grid.n}")
    return mesh


def check_homotopy_mesh(mesh) -> SegmentedMesh:
    """`check_segmented` for the condensed homotopy: LGR or LG segments."""
    return check_segmented(mesh, "a fuel-optimal transfer by the homotopy",
                           hint=": on LGL segments use method 'augmented-lagrangian'")


def check_grid(mesh, method):
    mesh = (check_homotopy_mesh(mesh) if method == "homotopy"
            else check_segmented(mesh, "a fuel-optimal transfer", condensed=False))
    if is_concrete(mesh.breaks):
        b = np.asarray(mesh.breaks)
        if b.ndim == 1 and not (abs(b[0]) < 1e-15 and abs(b[-1] - 1.0) < 1e-15):
            raise ValueError(f"mesh breaks are fractions of the transfer (of its anomaly span "
                             f"[s0, s_f]; of its time on a circular chief): they must run "
                             f"from 0 to 1, got [{b[0]}, {b[-1]}]")


def default_method(problem, mesh=None):
    """The augmented Lagrangian (`jaxlpm.solvers.fuel_constrained`) with safety constraints
    or on LGL segments (`mesh` a mesh or a `MeshLadder`), else the condensed homotopy."""
    if isinstance(mesh, MeshLadder):
        scheme = mesh.scheme
    else:
        segmented = as_segmented(mesh)
        scheme = segmented.grid.scheme if isinstance(segmented, SegmentedMesh) else None
    return ("augmented-lagrangian" if problem.constraints or scheme == "LGL"
            else "homotopy")


def run(problem, mesh, method, options) -> Solution:
    """Solve on one segmented mesh whose breaks are fractions of the independent variable's
    span [s0, s_f] (from 0 to 1; of the transfer time on a circular chief). jit-compiled
    once per mesh shape and options; vmap-able over problems and meshes. A solution's own
    `grid` (an `LGRMesh`, `LGMesh` or `LGLMesh` in tau) is accepted too. Traced bad input
    gives INVALID_INPUT. Method "homotopy" (`HomotopyOptions`; LGR or LG segments) for
    transfers without safety constraints; "augmented-lagrangian" (`FuelALOptions`; LGR, LG
    or LGL segments, the states kept) for any, the only one with safety constraints."""
    if method == "homotopy" and problem.constraints:
        raise ValueError("a fuel-optimal transfer with safety constraints is solved by method "
                         f"'augmented-lagrangian' (options FuelALOptions), got {method!r}")
    if method == "homotopy":
        check_homotopy_mesh(mesh)
    # traced too: one program, not op by op
    if method == "augmented-lagrangian":
        return constrained_fuel_optimal(problem, as_segmented(mesh), options)
    return _compiled(problem, as_segmented(mesh), options)


ALIGN_PASSES = 3     # passes per segment count: the switches move as the mesh follows them


def _ladder(segments, points=DEFAULT_POINTS, scheme="LGR"):
    return MeshLadder(tuple((k, points) for k in segments), scheme)


LADDER = _ladder((DEFAULT_SEGMENTS, 48, 96), scheme="LG")
"""The segment counts `solve(problem)` refines over (LG segments of `DEFAULT_POINTS` points:
over the 60 transfers of experiments/fuel_refine_dispersion.py 58 ended SUCCESS, against 48
on the same ladder of LGR segments, whose INACCURATE members all asked the engine more than
u_max between the points beside short or smoothed switches; docs/fuel-optimal.md)."""
# with safety constraints the states are kept; this ladder was sized when every Newton-KKT step
# factored the dense KKT matrix (~1900 unknowns at 16 x 8 points: 0.1-0.2 s). The condensed
# step makes finer rungs affordable; not yet evaluated as a default (on the approach case the
# finer meshes did not converge, docs/approach.md)
CONSTRAINED_LADDER = _ladder((16, 24))


def check_ladder(ladder: MeshLadder, condensed: bool = True) -> None:
    """A fuel-optimal ladder is of segments of at least `MIN_POINTS` points, LGR or LG ones
    for the condensed transcriptions (`condensed`: the homotopy, minimum-time method
    "condensed")."""
    schemes = CONDENSED_SCHEMES if condensed else SEGMENTED_SCHEMES
    if ladder.scheme not in schemes:
        raise ValueError(f"the homotopy and minimum-time method 'condensed' refine on LGR or "
                         f"LG segments (their states are eliminated segment by segment, and an "
                         f"LGL segment collocates both its ends; fuel-optimal and minimum-"
                         f"time transfers refine on LGL segments by method "
                         f"'augmented-lagrangian'), got a "
                         f"{ladder.scheme} ladder")
    if min(n for _, n in ladder.rungs) < MIN_POINTS:
        raise ValueError(f"the ladder's segments need at least {MIN_POINTS} points, got "
                         f"{ladder.rungs}")


def _cell_edges(weights) -> np.ndarray:
    """The edges of a segment's quadrature cells as fractions of it (n + 1 values from 0 to 1):
    point j stands for the cell [sum_{i<j} w_i, sum_{i<=j} w_i] / 2."""
    return np.concatenate([[0.0], np.cumsum(np.asarray(weights, np.float64))]) / 2.0


@functools.lru_cache(maxsize=None)
def switch_margins(scheme: str, n: int) -> tuple:
    """(before, after): how far (fractions of the coasting segment beside it) to put a break
    past a burn's start and short of its end, so that the partial-throttle point that the
    discrete bang-bang optimum puts at the switch (`burn_runs`) lies in the coasting segment,
    where the segment's control interpolant keeps within the bound.

    A segment whose points fire fully but for one partial point asks more than u_max between
    its points (node throttles 1, ..., 1, 0.5 on LGR(8): 1.035 u_max; 0.5, 1, ..., 1: 1.070),
    and so does a coasting segment whose last point fires much (its interpolant's
    extrapolation to the segment's end, l_n(1) = 1.6 on LGR(8)). For a switch at each
    position within a coasting segment the throttles are those of its cells (a burn ending
    there: 1 on the cells before it, the burned fraction on its own, 0 after; a burn starting
    there: mirrored), and the interpolant's peak (on 4001 points) stays at most 1 over a
    window from the segment's end that touches the burn; the margin is half that window, so
    that the next solution's switch may move by as much either way (measured on the keep-out
    flyby: docs/fuel-optimal.md, "Limits")."""
    grid = MESHES[scheme][1](n)
    edges = 2.0 * _cell_edges(grid.weights) - 1.0
    lo, hi = edges[:-1], edges[1:]
    at = interpolation_matrix(grid.points, grid.point_bary, np.linspace(-1.0, 1.0, 4001))
    candidates = np.linspace(-1.0, 1.0, 2001)

    def window(throttles):            # the safe length from the burn's side, in tau
        safe = np.array([np.max(np.abs(at @ throttles(t))) <= 1.0 + 1e-12 for t in candidates])
        return np.argmin(safe) * (candidates[1] - candidates[0]) if not safe.all() else 2.0

    after = window(lambda t: np.clip((t - lo) / (hi - lo), 0.0, 1.0))     # a burn ends at t
    before = window(lambda t: np.clip((hi + t) / (hi - lo), 0.0, 1.0))   # one starts at -t
    return before / 4.0, after / 4.0                  # half the window, as a fraction


COAST_RATIO = 2.0   # a break is moved only where the coasting segment beside it is at most
#                   this many times as long as the burning one: moved beside a much longer
#                   coasting segment, the partial point falls in one of its large cells, where
#                   the next switch estimate is too coarse to stay beside the break (the short
#                   one-segment burns of tests/test_refine_batch.py wandered into their burn
#                   segments)


def switch_breaks(k: int, runs, scheme: str = "LGR", n: int = DEFAULT_POINTS,
                  sharp=(), min_gap: float = 1e-6) -> np.ndarray:
    """k segments of [0, 1] with a break beside every switch of the burns `runs` (`burn_runs`:
    (start, end) fractions), or uniform ones where k segments cannot hold them all (k below
    the arcs between the switches): `aligned_breaks` at the switches, then the break of each
    bang-bang switch (`sharp`: per run, (start, end) flags of `sharp_switches`; missing: not
    sharp) moved into the burn by `switch_margins` of the coasting segment beside it (where
    that is at most `COAST_RATIO` times as long as the burning one beside it), so that the
    partial point at the switch falls in the coasting segment. Switches closer than min_gap
    (a fraction of the transfer) are merged (`aligned_breaks`)."""
    starts = [a for a, _ in runs if 0.0 < a < 1.0]
    ends = [b for _, b in runs if 0.0 < b < 1.0]
    if k < len(starts) + len(ends) + 1:
        return uniform_breaks(0.0, 1.0, k)
    b = aligned_breaks(0.0, 1.0, k, starts + ends, min_gap)
    before, after = switch_margins(scheme, n)
    moved = b.copy()
    for (start, end), (start_sharp, end_sharp) in zip(runs, sharp):
        for switch, sign, margin in ((start, 1.0, before * start_sharp),
                                     (end, -1.0, after * end_sharp)):
            i = int(np.argmin(np.abs(b - switch)))
            if margin > 0.0 and 0 < i < b.size - 1 and abs(b[i] - switch) <= 1e-12:
                coast, burn = (b[i] - b[i - 1], b[i + 1] - b[i])[::int(sign)]
                if coast <= COAST_RATIO * burn:
                    moved[i] = switch + sign * margin * coast
    return moved


def refine_transfer(problem, options, judge, ladder: MeshLadder | None = None,
                    passes: int = ALIGN_PASSES):
    """`solve(problem)` without a grid, or `solve(problem, ladder)`: a uniform mesh of the
    ladder's first rung (K segments of n points, LGR or LG by `ladder.scheme`), then, for
    each rung, up to `passes` meshes of its shape with a break at every switching time of
    the previous solution (`aligned_breaks`: the solution's switches move with the mesh, so
    the breaks follow them; `switch_breaks`), until the error estimate meets the tolerance
    (`judge` leaves it SUCCESS) or the last mesh (then INACCURATE). A solve that fails outright (not
    converged) ends the refinement with its status. stats gain mesh_passes.
    ladder: default `LADDER`, `CONSTRAINED_LADDER` with safety constraints. The method is
    `default_method(problem, ladder)`: the augmented Lagrangian with safety constraints or
    on an LGL ladder."""
    if ladder is None:
        ladder = CONSTRAINED_LADDER if problem.constraints else LADDER
    method = default_method(problem, ladder)
    check_ladder(ladder, condensed=method == "homotopy")
    if options is None:
        options = FuelALOptions() if method == "augmented-lagrangian" else HomotopyOptions()

    def solve_on(breaks, points):
        return judge(run(problem, segmented_mesh(breaks, points, ladder.scheme), method,
                         options))

    (k0, n0), done = ladder.rungs[0], 1
    solution = solve_on(uniform_breaks(0.0, 1.0, k0), n0)
    for k, n in (rung for rung in ladder.rungs for _ in range(passes)):
        if int(solution.status) != Status.INACCURATE:
            break
        solution = solve_on(next_breaks(*_throttles(solution), k, n, ladder.scheme, method), n)
        done += 1
    return solution.replace(stats=dict(solution.stats, mesh_passes=done))


FAMILY = FamilySolver(
    problem=FuelOptimalTransfer,
    methods={"homotopy": HomotopyOptions, "augmented-lagrangian": FuelALOptions}, run=run,
    default_grid=lambda problem: segmented_lgr(uniform_breaks(0.0, 1.0, DEFAULT_SEGMENTS),
                                               DEFAULT_POINTS),
    check_grid=check_grid, default_method=default_method, refine=refine_transfer,
    refine_method=default_method, ladders=True)


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class IndirectSolution:
    """Outcome of `indirect_fuel_optimal` (SI; see the fuel-optimal `Solution` for the fields)."""

    multipliers: jax.Array
    eps: jax.Array
    dv: jax.Array
    fuel: jax.Array
    terminal_error: jax.Array
    status: jax.Array
    homotopy_steps: jax.Array
    newton_iterations: jax.Array


def exact_linear_nlp(problem: FuelOptimalTransfer, breaks, nodes, weights):
    """(E, c, d) of the condensed problem (`FuelNLP`'s) on the linear model's exact flow: the
    Yamanaka-Ankersen STM from each quadrature node to f_f times the input gain, Gauss nodes
    and weights on panels with the given breaks (fractions of [f0, f_f]), no collocation."""
    o, energy = problem.orbit, problem.energy_problem()
    s0, sf = o.f0, kepler_final_anomaly(o, problem.duration)
    h = 0.5 * jnp.diff(breaks * (sf - s0))
    f = (s0 + breaks[:-1, None] * (sf - s0) + h[:, None] * (nodes[None] + 1.0)).reshape(-1)
    W = (h[:, None] * weights[None]).reshape(-1)
    T = problem.duration
    flow = jax.vmap(lambda fi: yamanaka_ankersen_stm(
        sf, fi, T - time_from_true_anomaly(o, fi), o.e, o.k2) @ _input_gain(fi, o.e))(f)
    rate = o.mean_motion / (o.k2 * (1.0 + o.e * jnp.cos(f)) ** 2)       # n dt/df
    umax = problem.max_acceleration / control_scale(energy)
    x0, xf = model_state(energy, problem.x0, s0), model_state(energy, problem.xf, sf)
    return (umax * flow * W[:, None, None], umax * W * rate,
            xf - yamanaka_ankersen_stm(sf, s0, T, o.e, o.k2) @ x0)


def panel_quadrature(breaks, points):
    """(breaks, nodes, weights) as arrays for `exact_linear_nlp`: the panels' breaks checked
    (strictly increasing fractions of [f0, f_f] from 0 to 1) and `points` Gauss-Legendre
    nodes and weights; a ValueError names what is wrong."""
    b = np.asarray(breaks, dtype=np.float64)
    if b.ndim != 1 or b.size < 2 or not np.all(np.diff(b) > 0) or b[0] != 0.0 or b[-1] != 1.0:
        raise ValueError("breaks must increase strictly from 0 to 1 (fractions of [f0, f_f])")
    if isinstance(points, bool) or not isinstance(points, int) or points < 1:
        raise ValueError(f"points must be a positive integer, got {points!r}")
    nodes, weights = lg_nodes_weights(points)
    return jnp.asarray(b), jnp.asarray(nodes), jnp.asarray(weights)


def _indirect(problem, breaks, nu0, nodes, weights, options):
    energy = problem.energy_problem()
    sf = kepler_final_anomaly(problem.orbit, problem.duration)
    E, c, d = exact_linear_nlp(problem, breaks, nodes, weights)
    res = energy_to_fuel(E, c, d, nu0, options)
    v = controls(res.nu, E, c, res.eps)
    dv = jnp.sum(c * jnp.linalg.norm(v, axis=1)) * delta_v_unit(problem)
    miss = lvlh_state(energy, jnp.einsum("iab,ib->a", E, v) - d, sf)
    return IndirectSolution(
        multipliers=res.nu, eps=res.eps, dv=dv, fuel=rocket_fuel(dv, problem),
        terminal_error=jnp.stack([jnp.linalg.norm(miss[:3]), jnp.linalg.norm(miss[3:])]),
        status=res.status, homotopy_steps=res.steps, newton_iterations=res.newton_iterations)


_indirect_compiled = compiled(_indirect, static_argnames="options")


def indirect_fuel_optimal(problem: FuelOptimalTransfer, breaks, nu0=None, points: int = 8,
                          options: HomotopyOptions = HomotopyOptions()) -> IndirectSolution:
    """The indirect method (Yue & Duan 2016 §2.2) on the linear model: Pontryagin's
    conditions with the smoothed switching law, shooting on the costates, continued in eps
    from eps = 1.

    The Tschauner-Hempel costate is lambda(f) = Phi(f_f, f)^T nu (Phi the Yamanaka-Ankersen
    STM; on HCW exp(A^T (s_f - s)) nu), so shooting on lambda(0) is shooting on nu (one-to-
    one); the control is the law of `jaxlpm.problems.fuel_optimal` on the primer (module
    docstring), and the shooting residual x(f_f) - xf = Phi(f_f, f0) x0 + int Phi(f_f, f)
    B(f) u(p(f)) df - xf is integrated by Gauss-Legendre quadrature (`points` nodes) on panels
    with the given breaks (fractions of [f0, f_f] from 0 to 1, those of a solution's mesh; put
    breaks at the switching times so each panel is smooth). nu0: the first guess (the LGR
    solution's `energy_multipliers`: the paper's initialisation from the pseudospectral
    costates). Shares the homotopy and Newton solver of the direct method: the two differ only
    in how the state equation is discretised (exact flow and quadrature here, LGR collocation
    there)."""
    require_x64()
    check_fuel_problem(problem)
    if problem.model != "linear":
        raise ValueError(f"indirect_fuel_optimal shoots on the linear model's exact flow, got "
                         f"model {problem.model!r}")
    b, nodes, weights = panel_quadrature(breaks, points)
    nu0 = jnp.zeros(6) if nu0 is None else jnp.asarray(nu0)
    if nu0.shape != (6,):
        raise ValueError(f"nu0 must have shape (6,), got {nu0.shape}")
    return _indirect_compiled(problem, b, nu0, nodes, weights, options)


def _throttles(sol: Solution):
    """(breaks as fractions, segment weights, node throttles, burn threshold) of an
    unbatched solution: what `burn_runs` and `next_breaks` read."""
    return (0.5 * (np.asarray(sol.grid.breaks) + 1.0), sol.grid.segment.weights,
            sol.stats["node_throttle"], sol.stats.get("burn_threshold", BURNING))


def _burn_runs(sol: Solution):
    """[(start, end)] of the burns as fractions of [s0, s_f] (unbatched solution):
    `burn_runs` of its mesh and throttles."""
    return burn_runs(*_throttles(sol))


MIN_RUN = 1e-3    # a burn inside the transfer shorter than this fraction of the mesh's shortest
#                  segment is not aligned with (`next_breaks`)
MIN_GAP = {"homotopy": 1e-6, "augmented-lagrangian": 1e-3}
"""Per method, switches closer than this fraction of the transfer share a break
(`switch_breaks`). The augmented Lagrangian's Newton-KKT systems hold the states, whose
defects scale as 1 / (segment length): on segments of 7.8e-5 and 6.1e-6 of the transfer (two
switches of a short burn) every eps step of two dispersed transfers ended MAX_ITERATIONS on
LGL segments, and with 1e-3 each of their meshes converged; the condensed homotopy eliminates
the states and keeps such segments (8 s burns after 235 s of coast, docs/accuracy.md)."""


def next_breaks(breaks, weights, throttle, threshold, k: int, n: int, scheme: str,
                method: str = "homotopy") -> np.ndarray:
    """`switch_breaks` for the next mesh (k segments of n points of `scheme`) from a mesh's
    breaks (fractions), its segment's weights and the throttles at its points (host, as
    `burn_runs` takes them). A burn inside the transfer shorter than `MIN_RUN` of the
    shortest segment gets no breaks: such a run is one point that barely fires, most often
    an LGL segment's end (its control weakly determined, both ends being collocated; on the
    keep-out flyby a point at a break fired at 0.033 of the bound, a 3.7e-5 run), and its two
    breaks would make a segment that short (the next mesh's solve then ended MAX_ITERATIONS
    at every eps). Switches closer than `MIN_GAP` of `method` share a break."""
    runs = burn_runs(breaks, weights, throttle, threshold)
    shortest = MIN_RUN * float(np.min(np.diff(np.asarray(breaks, np.float64))))
    kept = [i for i, (a, b) in enumerate(runs) if a == 0.0 or b == 1.0 or b - a >= shortest]
    sharp = sharp_switches(throttle, threshold)
    return switch_breaks(k, [runs[i] for i in kept], scheme, n, [sharp[i] for i in kept],
                         MIN_GAP[method])


def burn_runs(breaks, weights, throttle, threshold=BURNING):
    """[(start, end)] of the burns as fractions of [s0, s_f], from the mesh's breaks (as
    fractions), its segment's LGR weights and the throttles at its points (host, NumPy): the
    runs of collocation points that fire (throttle > threshold), each point standing for its
    quadrature cell (the cumulative LGR weights of its segment). A run's end point with a
    partial throttle w fires for the fraction w of its cell, on the run's side; a run of one
    point is centred on it; a run that reaches an end of the transfer burns from (to) it. This
    impulse-equivalent estimate is the discrete solution's own: a bang-bang optimum on a mesh
    puts one partial point at each switch, where |p| sits within eps of 1, so the primer's
    crossing lies at that point and not at the switch."""
    b = np.asarray(breaks, np.float64)
    cells = _cell_edges(weights)
    lo = (b[:-1, None] + np.diff(b)[:, None] * cells[None, :-1]).reshape(-1)
    hi = (b[:-1, None] + np.diff(b)[:, None] * cells[None, 1:]).reshape(-1)
    w = np.asarray(throttle).reshape(-1)
    runs = []
    for i, j in _firing(w, threshold):
        if i == j:
            half = 0.5 * w[i] * (hi[i] - lo[i])
            start, end = 0.5 * (lo[i] + hi[i]) - half, 0.5 * (lo[i] + hi[i]) + half
        else:
            start, end = hi[i] - w[i] * (hi[i] - lo[i]), lo[j] + w[j] * (hi[j] - lo[j])
        # a run at an end of the transfer burns from (to) that end
        runs.append((0.0 if i == 0 else start, 1.0 if j == w.size - 1 else end))
    return runs


def _firing(w, threshold):
    """[(i, j)]: the runs of consecutive points i..j of the throttles w (flat) above
    threshold."""
    on = np.asarray(w) > float(threshold)
    edges = np.flatnonzero(np.diff(np.concatenate([[0], on.astype(int), [0]])))
    return list(zip(edges[::2], edges[1::2] - 1))


FULL = 1.0 - 1e-3          # a point fires fully where its throttle is at least this


def sharp_switches(throttle, threshold=BURNING):
    """[(start, end)] per run of `burn_runs`: whether the burn fires fully (`FULL`) at the
    point next to the switch's partial one, inside the run: a bang-bang switch, where
    `switch_breaks` moves the break (a burn whose throttle ramps, as a short burn whose
    primer only touches 1 does, keeps its break at the switch)."""
    w = np.asarray(throttle).reshape(-1)
    return [(j > i and w[i + 1] >= FULL, j > i and w[j - 1] >= FULL)
            for i, j in _firing(w, threshold)]


def interior_switches(runs):
    """The burn starts and ends strictly inside (0, 1) of `burn_runs`' runs, ascending."""
    return np.sort(np.asarray([x for arc in runs for x in arc if 0.0 < x < 1.0],
                              dtype=np.float64))


@compiled
def _times(sol, fractions):
    """Times (s) at fractions of [s0, s_f]: each segment's interpolated state-row times."""
    tr = sol.trajectory
    return jax.vmap(lambda f: tr.grid.interpolate_state(tr.state_times, 2.0 * f - 1.0))(
        fractions)


def switching_fractions(sol: Solution):
    """The switches (burn starts and ends inside the transfer, `burn_arcs`) as fractions of
    [s0, s_f], the coordinates of a mesh's breaks: ascending NumPy array (unbatched)."""
    return interior_switches(_burn_runs(sol))


def switching_times(sol: Solution):
    """The switching times (s since the start, ascending NumPy array; unbatched solution):
    `switching_fractions` in time."""
    sw = switching_fractions(sol)
    return np.asarray(_times(sol, jnp.asarray(sw))) if sw.size else sw


def burn_arcs(sol: Solution):
    """[(start, end)] (s) of the burns (unbatched solution; `_burn_runs`: the collocation
    points that fire, switches at their impulse-equivalent edges)."""
    runs = _burn_runs(sol)
    if not runs:
        return []
    t = np.asarray(_times(sol, jnp.asarray(np.asarray(runs, dtype=np.float64).reshape(-1))))
    return [(float(a), float(b)) for a, b in t.reshape(-1, 2)]


def _member(tree, i):
    return jax.tree_util.tree_map(lambda x: x[i], tree)


@compiled(static_argnames=("options", "width"))
def _grouped_pass(problems, breaks, grid, options, width):
    """`_refine_pass` in vmapped groups of `width` members (`jaxlpm.mapping.map_in_groups`)."""
    return map_in_groups(
        lambda pb: _fuel_optimal_transfer(pb[0], SegmentedMesh(breaks=pb[1], grid=grid), options),
        (problems, breaks), width)


def _refine_pass(problems, breaks, grid, options, width):
    """One pass of `refine_fuel_optimal`: every member on its own mesh (breaks (B, K + 1),
    segments of `grid`).
    Width 1: member by member through the one-problem program (`jaxlpm.solve`'s, whatever
    the number of members), the solutions stacked on the host; else `_grouped_pass`."""
    if width > 1:
        return _grouped_pass(problems, breaks, grid, options, width)
    host = jax.tree_util.tree_map(np.asarray, problems)
    solutions = [_compiled(_member(host, i), SegmentedMesh(breaks=breaks[i], grid=grid), options)
                 for i in range(np.shape(breaks)[0])]
    return jax.tree_util.tree_map(lambda *xs: np.stack([np.asarray(x) for x in xs]), *solutions)


def refine_fuel_optimal(problems: FuelOptimalTransfer, segments: int = 24, points: int = 8,
                        fuel_tol: float = 1e-4, max_passes: int = 5,
                        options: HomotopyOptions = HomotopyOptions(),
                        width: int = 1, scheme: str = "LGR") -> Solution:
    """Solve a batch of problems (leading axis on every array leaf but scalars, which the
    members share; one problem: add it with `jax.tree_util.tree_map(lambda x: x[None], p)`)
    on `segments` segments of `points` points (`scheme` "LGR", the default, or "LG"):
    first a uniform mesh, then meshes with breaks at the previous switching times,
    until every member's fuel changes by less than fuel_tol (relative) or max_passes.
    A pass solves the members one after the other (width 1, the default: each homotopy to its
    own number of steps, by `jaxlpm.solve`'s compiled program) or in vmapped groups of
    `width` in one compiled call (`jaxlpm.batch.map_in_groups`). On the CPU one at a time is
    the faster: yue2016's sweep of 42 members took 3.8 s a pass so, against 9-11 s vmapped
    (2026-12-06, 2-core VM, the fast compile profile; a vmapped homotopy runs every member to
    the slowest one's steps, here 155 Newton iterations against a median of 64, and both
    branches of every `lax.cond`); a wide `width` is for accelerators. Returns the last
    pass's batched `Solution` (host arrays when width is 1), its stats extended by the
    refinement, one row per member: passes (B,), fuel_by_pass (B, passes)
    (kg) and fuel_change (B,) (relative change of the last pass; inf after a single pass)."""
    require_x64()
    if not isinstance(problems, FuelOptimalTransfer):
        raise ValueError(f"problems must be a FuelOptimalTransfer, got "
                         f"{type(problems).__name__}")
    size = np.shape(problems.duration)
    if len(size) != 1:
        raise ValueError(f"problems must carry one leading batch axis, got duration shape {size}")
    # scalar leaves (a default such as j2, or one orbit for all) are shared by every member
    problems = jax.tree_util.tree_map(
        lambda x: jnp.broadcast_to(x, size) if np.ndim(x) == 0 else x, problems)
    for i in range(size[0]):
        _member(problems, i).validate()
    if isinstance(width, bool) or not isinstance(width, (int, np.integer)) or width < 1:
        raise ValueError(f"width must be a positive integer, got {width!r}")
    grid_mesh = segmented_mesh(uniform_breaks(0.0, 1.0, segments), points, scheme)
    check_grid(grid_mesh, "homotopy")
    breaks = np.tile(np.asarray(grid_mesh.breaks), (size[0], 1))
    fuels = []
    for _ in range(max_passes):
        sol = _refine_pass(problems, breaks, grid_mesh.grid, options, int(width))
        fuels.append(np.asarray(sol.stats["fuel"]))
        change = (np.abs(fuels[-1] - fuels[-2]) / np.abs(fuels[-1]) if len(fuels) > 1
                  else np.full(size[0], np.inf))
        if np.all(change < fuel_tol) or len(fuels) == max_passes:
            break
        new = []
        for i in range(size[0]):
            new.append(next_breaks(*_throttles(_member(sol, i)), segments, points, scheme))
        breaks = np.stack(new)
    stats = dict(sol.stats, passes=np.full(size[0], len(fuels)),
                 fuel_by_pass=np.stack(fuels, axis=1), fuel_change=change)
    return dataclasses.replace(sol, stats=stats)
