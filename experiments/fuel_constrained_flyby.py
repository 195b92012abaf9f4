"""The cost of the fuel-optimal continuation with a safety constraint (issue 22,
`jaxlpm.solvers.fuel_constrained`): the keep-out flyby of tests/test_fuel_constrained.py
(e = 0.05, linear model, 1500 m sphere, 0.5 N on 100 kg) on 16 LGR segments of 8 points.
Prints, per eps of the schedule, the status, the delta-v and the Newton and outer iterations,
then the total time of the call (compile included) and the unconstrained fuel optimum of the
same mesh (the condensed homotopy).

With --refine, the default solve instead (`jaxlpm.solve(problem)`, no grid: the fuel family's
refinement, meshes aligned with the switches): per mesh its segments, status after the judge,
each continuation step's status and outer iterations, the error estimate and the violations
between the nodes; then where the thrust excess lies (the segments holding it and their node
throttles) and the final solution flown on the linear model (`jaxlpm.verify.fly`).
--tol-path and --inner set the augmented Lagrangian's path tolerance and Newton iterations a
subproblem (FuelALOptions().al's by default).

    python experiments/fuel_constrained_flyby.py
    python experiments/fuel_constrained_flyby.py --refine [--tol-path 1e-7 --inner 40]
"""

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from test_fuel_constrained import flyby  # noqa: E402

import jaxlpm as lpm  # noqa: E402


def refined(options, scheme):
    """The default solve, each mesh printed as it is judged (module docstring)."""
    from jaxlpm.solution import Judge
    from jaxlpm.solvers import fuel_optimal

    run = fuel_optimal.run

    def logged(problem, mesh, method, opts):
        t = time.perf_counter()
        sol = Judge()(run(problem, mesh, method, opts))
        st = sol.stats
        steps = " ".join(f"{lpm.Status(int(a)).name}({int(b)})" for a, b in
                         zip(np.asarray(st["status_by_eps"]), np.asarray(st["outer_by_eps"])))
        v = np.asarray(st["constraint_violation"])
        print(f"{mesh.n_segments} x {mesh.grid.n}: {lpm.Status(int(sol.status)).name}, "
              f"delta-v {float(sol.cost):.6f} m/s, steps {steps}; estimate "
              f"{float(st['error_position']):.1e} m, zone {v[0]:.1e} m, thrust excess "
              f"{float(st['path_violation']):.1e} m/s ({time.perf_counter() - t:.1f} s)",
              flush=True)
        return sol

    fuel_optimal.run = logged
    try:
        t = time.perf_counter()
        ladder = lpm.MeshLadder(fuel_optimal.CONSTRAINED_LADDER.rungs, scheme)
        sol = lpm.solve(flyby(1500.0), ladder, options=options, throw=False)
    finally:
        fuel_optimal.run = run
    print(f"default solve: {lpm.Status(int(sol.status)).name} after "
          f"{int(sol.stats['mesh_passes'])} meshes, {time.perf_counter() - t:.1f} s")
    where_the_thrust_exceeds(sol)
    flight = lpm.verify.fly(sol, model="linear")
    miss = np.asarray(flight.terminal_error)
    print(f"flown on the linear model: terminal miss {miss[0]:.2e} m, {miss[1]:.2e} m/s")


def where_the_thrust_exceeds(sol):
    """The segments whose control interpolant exceeds u_max, with their node throttles."""
    t = np.linspace(0.0, float(sol.duration), 40001)
    tau = np.asarray(jax.vmap(sol.trajectory.tau)(t))
    u = np.linalg.norm(np.asarray(sol.controls(t)), axis=1) / float(
        sol.problem.max_acceleration)
    breaks = np.asarray(sol.grid.breaks)
    throttle = np.asarray(sol.stats["node_throttle"])
    segment_of = np.clip(np.searchsorted(breaks, tau, side="right") - 1, 0, breaks.size - 2)
    for k in np.unique(segment_of[u > 1.0 + 1e-9]):
        inside = segment_of == k
        print(f"  segment {k} (tau {breaks[k]:.4f} to {breaks[k + 1]:.4f}): largest throttle "
              f"{u[inside].max():.4f}; node throttles {np.round(throttle[k], 3).tolist()}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--refine", action="store_true", help="the default solve (no grid)")
    ap.add_argument("--tol-path", type=float, default=None)
    ap.add_argument("--inner", type=int, default=None)
    ap.add_argument("--scheme", default="LGR", choices=("LGR", "LG", "LGL"),
                    help="the segments of --refine's ladder (the constrained ladder's shapes)")
    args = ap.parse_args()
    options = lpm.FuelALOptions()
    al = dataclasses.replace(options.al, tol_path=args.tol_path or options.al.tol_path,
                             inner=dataclasses.replace(options.al.inner, max_iterations=(
                                 args.inner or options.al.inner.max_iterations)))
    options = dataclasses.replace(options, al=al)
    if args.refine:
        return refined(options, args.scheme)
    mesh = lpm.segmented_lgr(lpm.uniform_breaks(0.0, 1.0, 16), 8)
    t = time.perf_counter()
    sol = jax.block_until_ready(lpm.solve(flyby(1500.0), mesh, options=options,
                                            throw=False))
    seconds = time.perf_counter() - t
    st = sol.stats
    print("| eps | status | delta-v (m/s) | Newton iterations | outer iterations |")
    print("|---|---|---|---|---|")
    for row in zip(np.asarray(st["eps_schedule"]), np.asarray(st["status_by_eps"]),
                   np.asarray(st["dv_by_eps"]), np.asarray(st["iterations_by_eps"]),
                   np.asarray(st["outer_by_eps"])):
        print(f"| {row[0]:g} | {lpm.Status(int(row[1])).name} | {row[2]:.6f} | {row[3]} "
              f"| {row[4]} |")
    free = lpm.solve(flyby(1500.0).replace(constraints=()), mesh, throw=False)
    print(f"{lpm.Status(int(sol.status)).name}: delta-v {float(sol.cost):.6f} m/s, "
          f"{int(np.sum(st['iterations_by_eps']))} Newton iterations, {seconds:.1f} s with "
          f"compilation; without the zone (condensed homotopy) {float(free.cost):.6f} m/s")


if __name__ == "__main__":
    main()
