"""Fuel-optimal bounded-thrust transfers on HCW (`jaxlpm.problems.fuel_optimal`) by segmented
LGR collocation and the energy-to-fuel homotopy (`jaxlpm.nlp.homotopy`), with mesh
refinement at the switching times (Yue & Duan 2016's pipeline: an energy-optimal Radau
pseudospectral solution, then the homotopy to the bang-bang fuel optimum).

`jaxlpm.solve(problem, mesh)` (`run`): one mesh (jit; vmap over problems and meshes of one
shape). `jaxlpm.solve(problem)`: mesh refinement to the accuracy tolerance
(`refine_transfer`). `indirect_fuel_optimal(problem, breaks)`: the paper's indirect method,
shooting on the costates with the smoothed switching law, continued in eps from the LGR costates.
`refine_fuel_optimal(problems, segments, points)`: host-side passes over meshes with a break at
every switching time of the previous solution (`aligned_breaks`), the first mesh uniform, until
the fuel changes by less than `fuel_tol` (relative); a batch of problems is one vmapped call
per pass.

Switching function (the primer vector from the costates): on HCW the costate obeys
lambda' = -A^T lambda exactly, and the final-state multiplier nu gives the primer
p(s) = -B^T exp(A^T (s_f - s)) nu, |p| the switching function (threshold 1; rho = 1 - |p| in the
paper's eq. 34). At the collocation points the estimates p_i = -E_i^T nu / c_i (the LGR costate
estimates, Garg et al. 2010) agree with it to the mesh's accuracy. Burn arcs are where |p| > 1.
"""

import dataclasses
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from ..compilation import compiled
from .._validation import is_concrete, require_x64
from ..collocation import lg_nodes_weights
from ..collocation.segments import SegmentedMesh, aligned_breaks, segmented_lgr, uniform_breaks
from ..dynamics import hcw_flow
from ..problems.fuel_optimal import (FuelOptimalTransfer, check_fuel_problem,
                                     hcw_input_matrices, rocket_fuel, to_nlp, to_solution)
from ..problems.scaling import length_scale, state_scale
from ..nlp.homotopy import HomotopyOptions, controls, energy_to_fuel
from ..solution import Solution
from ..status import Status
from .family import FamilySolver

MIN_POINTS = 3
MAX_SWITCHES = 16          # switching times found per solution (burn arcs = switches / 2)
SCAN_POINTS = 20001        # samples of |p(t)| searched for switches (then bisection)


def primer(sol, t):
    """Primer vector p(t) (3,) of a fuel-optimal `Solution` from its costates (module
    docstring), t in s since the start."""
    n = sol.problem.orbit.mean_motion
    _, B = hcw_input_matrices()
    flow = hcw_flow(n * (sol.problem.duration - t))
    return -B.T @ flow.T @ sol.stats["multipliers"]


def switching_function(sol, t):
    """rho(t) = 1 - |p(t)| (Yue & Duan 2016 eq. 34): the engine fires where rho < 0."""
    return 1.0 - jnp.linalg.norm(primer(sol, t))


def _fuel_optimal_transfer(problem, mesh, options):
    valid = problem.validity()
    problem = problem.sanitized(valid)
    nlp = to_nlp(problem, mesh)
    return to_solution(problem, mesh, nlp, energy_to_fuel(nlp.E, nlp.c, nlp.d, options=options),
                       valid)


_compiled = compiled(_fuel_optimal_transfer, static_argnames="options")


DEFAULT_SEGMENTS, DEFAULT_POINTS = 24, 8     # Yue & Duan 2016's mesh


def check_grid(mesh, method):
    if not isinstance(mesh, SegmentedMesh):
        raise ValueError(f"the grid of a fuel-optimal transfer is a SegmentedMesh "
                         f"(segmented_lgr(breaks, n), breaks as fractions of the duration), "
                         f"got {type(mesh).__name__}")
    if mesh.grid.n < MIN_POINTS:
        raise ValueError(f"fuel-optimal transfers need at least {MIN_POINTS} LGR points per "
                         f"segment, got {mesh.grid.n}")
    if is_concrete(mesh.breaks):
        b = np.asarray(mesh.breaks)
        if b.ndim == 1 and not (abs(b[0]) < 1e-15 and abs(b[-1] - 1.0) < 1e-15):
            raise ValueError(f"mesh breaks are fractions of the transfer time: they must run "
                             f"from 0 to 1, got [{b[0]}, {b[-1]}]")


def run(problem, mesh, method, options: HomotopyOptions) -> Solution:
    """Solve on one segmented LGR mesh whose breaks are fractions of the transfer time (from
    0 to 1). jit-compiled once per mesh shape and options; vmap-able over problems and
    meshes. Traced bad input gives INVALID_INPUT."""
    return _compiled(problem, mesh, options)      # traced too: one program, not op by op


REFINE_SEGMENTS = (DEFAULT_SEGMENTS, 48, 96)
ALIGN_PASSES = 3     # passes per segment count: the switches move as the mesh follows them


def refine_transfer(problem, options, judge, segments=REFINE_SEGMENTS,
                    points: int = DEFAULT_POINTS, passes: int = ALIGN_PASSES):
    """`solve(problem)` without a grid: a uniform mesh of segments[0] LGR segments of `points`
    points, then, for each count in `segments`, up to `passes` meshes with a break at every
    switching time of the previous solution (`aligned_breaks`: the solution's switches move
    with the mesh, so the breaks follow them), until the error estimate meets the tolerance
    (`judge` leaves it SUCCESS) or the last mesh (then INACCURATE). A solve that fails
    outright (not converged) ends the refinement with its status. stats gain mesh_passes."""
    options = HomotopyOptions() if options is None else options

    def solve_on(breaks):
        return judge(run(problem, segmented_lgr(breaks, points), "homotopy", options))

    T = float(problem.duration)
    solution, done = solve_on(uniform_breaks(0.0, 1.0, segments[0])), 1
    for count in (count for count in segments for _ in range(passes)):
        if int(solution.status) != Status.INACCURATE:
            break
        solution = solve_on(aligned_breaks(0.0, 1.0, count, switching_times(solution) / T))
        done += 1
    return solution.replace(stats=dict(solution.stats, mesh_passes=done))


FAMILY = FamilySolver(
    problem=FuelOptimalTransfer, methods={"homotopy": HomotopyOptions}, run=run,
    default_grid=lambda problem: segmented_lgr(uniform_breaks(0.0, 1.0, DEFAULT_SEGMENTS),
                                               DEFAULT_POINTS),
    check_grid=check_grid, refine=refine_transfer, refine_method="homotopy")


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


def _indirect(problem, breaks, nu0, nodes, weights, options):
    n = problem.orbit.mean_motion
    scale, L = state_scale(problem), length_scale(problem)
    umax = problem.max_acceleration / (L * n**2)
    sf = n * problem.duration
    _, B = hcw_input_matrices()
    h = 0.5 * jnp.diff(breaks * sf)
    s = (breaks[:-1, None] * sf + h[:, None] * (nodes[None] + 1.0)).reshape(-1)
    W = (h[:, None] * weights[None]).reshape(-1)
    flow = jax.vmap(lambda si: hcw_flow(sf - si) @ B)(s)
    E, c = umax * flow * W[:, None, None], umax * W
    x0, xf = problem.x0 / scale, problem.xf / scale
    d = xf - hcw_flow(sf) @ x0
    res = energy_to_fuel(E, c, d, nu0, options)
    v = controls(res.nu, E, c, res.eps)
    dv = jnp.sum(c * jnp.linalg.norm(v, axis=1)) * L * n
    miss = (jnp.einsum("iab,ib->a", E, v) - d) * scale
    return IndirectSolution(
        multipliers=res.nu, eps=res.eps, dv=dv, fuel=rocket_fuel(dv, problem),
        terminal_error=jnp.stack([jnp.linalg.norm(miss[:3]), jnp.linalg.norm(miss[3:])]),
        status=res.status, homotopy_steps=res.steps, newton_iterations=res.newton_iterations)


_indirect_compiled = compiled(_indirect, static_argnames="options")


def indirect_fuel_optimal(problem: FuelOptimalTransfer, breaks, nu0=None, points: int = 8,
                          options: HomotopyOptions = HomotopyOptions()) -> IndirectSolution:
    """The indirect method (Yue & Duan 2016 §2.2): Pontryagin's conditions with the smoothed
    switching law, shooting on the costates, continued in eps from eps = 1.

    The costate of HCW is lambda(s) = exp(A^T (s_f - s)) nu (`hcw_flow`), so shooting on
    lambda(0) is shooting on nu (one-to-one); the control is the law of
    `jaxlpm.problems.fuel_optimal` on
    the primer p(s) = -B^T lambda_v(s), and the shooting residual
    x(s_f) - xf = exp(A s_f) x0 + int exp(A (s_f - s)) B u(p(s)) ds - xf is integrated by
    Gauss-Legendre quadrature (`points` nodes) on panels with the given breaks (fractions of
    t_f from 0 to 1; put breaks at the switching times so each panel is smooth). nu0: the
    first guess (the LGR solution's `energy_multipliers`: the paper's initialisation from the
    pseudospectral costates). Shares the homotopy and Newton solver of the direct method: the
    two differ only in how the state equation is discretised (exact flow and quadrature here,
    LGR collocation there)."""
    require_x64()
    check_fuel_problem(problem)
    b = np.asarray(breaks, dtype=np.float64)
    if b.ndim != 1 or b.size < 2 or not np.all(np.diff(b) > 0) or b[0] != 0.0 or b[-1] != 1.0:
        raise ValueError("breaks must increase strictly from 0 to 1 (fractions of t_f)")
    if isinstance(points, bool) or not isinstance(points, int) or points < 1:
        raise ValueError(f"points must be a positive integer, got {points!r}")
    nodes, weights = lg_nodes_weights(points)
    nu0 = jnp.zeros(6) if nu0 is None else jnp.asarray(nu0)
    if nu0.shape != (6,):
        raise ValueError(f"nu0 must have shape (6,), got {nu0.shape}")
    return _indirect_compiled(problem, jnp.asarray(b), nu0, jnp.asarray(nodes),
                              jnp.asarray(weights), options)


@compiled
def _primer_norm(sol, ts):
    return jax.vmap(lambda t: jnp.linalg.norm(primer(sol, t)))(ts)


def switching_times(sol: Solution, max_switches: int = MAX_SWITCHES):
    """Times (s, ascending NumPy array) where |p(t)| crosses 1 (unbatched solution): a scan
    of SCAN_POINTS samples, then 60 bisections of each bracketed crossing."""
    T = float(sol.problem.duration)
    ts = np.linspace(0.0, T, SCAN_POINTS)
    f = np.asarray(_primer_norm(sol, jnp.asarray(ts))) - 1.0
    idx = np.nonzero(np.sign(f[:-1]) * np.sign(f[1:]) < 0)[0][:max_switches]
    lo, hi = ts[idx], ts[idx + 1]
    flo = f[idx]
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        fm = np.asarray(_primer_norm(sol, jnp.asarray(mid))) - 1.0 if mid.size else mid
        left = np.sign(fm) == np.sign(flo)
        lo, hi, flo = np.where(left, mid, lo), np.where(left, hi, mid), np.where(left, fm, flo)
    return 0.5 * (lo + hi)


def burn_arcs(sol: Solution):
    """[(start, end)] (s) of the burns: the arcs where |p(t)| > 1 (unbatched solution)."""
    T = float(sol.problem.duration)
    sw = switching_times(sol)
    edges = np.concatenate([[0.0], sw, [T]])
    mids = 0.5 * (edges[:-1] + edges[1:])
    on = np.asarray(_primer_norm(sol, jnp.asarray(mids))) > 1.0
    return [(float(a), float(b)) for a, b, burn in zip(edges[:-1], edges[1:], on) if burn]


def _member(tree, i):
    return jax.tree_util.tree_map(lambda x: x[i], tree)


def refine_fuel_optimal(problems: FuelOptimalTransfer, segments: int = 24, points: int = 8,
                        fuel_tol: float = 1e-4, max_passes: int = 5,
                        options: HomotopyOptions = HomotopyOptions()) -> Solution:
    """Solve a batch of problems (leading axis on every array leaf; one problem: add it with
    `jax.tree_util.tree_map(lambda x: x[None], p)`) on `segments` LGR segments of `points`
    points: first a uniform mesh, then meshes with breaks at the previous switching times,
    until every member's fuel changes by less than fuel_tol (relative) or max_passes.
    Each pass is one vmapped call. Returns the last pass's batched `Solution`, its stats
    extended by the refinement, one row per member: passes (B,), fuel_by_pass (B, passes)
    (kg) and fuel_change (B,) (relative change of the last pass; inf after a single pass)."""
    require_x64()
    if not isinstance(problems, FuelOptimalTransfer):
        raise ValueError(f"problems must be a FuelOptimalTransfer, got "
                         f"{type(problems).__name__}")
    size = np.shape(problems.duration)
    if len(size) != 1:
        raise ValueError(f"problems must carry one leading batch axis, got duration shape {size}")
    for i in range(size[0]):
        _member(problems, i).validate()
    grid_mesh = segmented_lgr(uniform_breaks(0.0, 1.0, segments), points)
    check_grid(grid_mesh, "homotopy")
    solve = jax.jit(jax.vmap(lambda p, b: _fuel_optimal_transfer(
        p, SegmentedMesh(breaks=b, grid=grid_mesh.grid), options)))
    breaks = np.tile(np.asarray(grid_mesh.breaks), (size[0], 1))
    fuels = []
    for _ in range(max_passes):
        sol = solve(problems, jnp.asarray(breaks))
        fuels.append(np.asarray(sol.stats["fuel"]))
        change = (np.abs(fuels[-1] - fuels[-2]) / np.abs(fuels[-1]) if len(fuels) > 1
                  else np.full(size[0], np.inf))
        if np.all(change < fuel_tol) or len(fuels) == max_passes:
            break
        new = []
        for i in range(size[0]):
            member = _member(sol, i)
            T = float(member.problem.duration)
            sw = switching_times(member) / T
            new.append(aligned_breaks(0.0, 1.0, segments, sw))
        breaks = np.stack(new)
    stats = dict(sol.stats, passes=np.full(size[0], len(fuels)),
                 fuel_by_pass=np.stack(fuels, axis=1), fuel_change=change)
    return dataclasses.replace(sol, stats=stats)
