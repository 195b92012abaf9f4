"""The approach case's fuel-optimal solve on meshes split where its constraints fail
(issue 19, docs/approach.md "What does not work yet"): 16 uniform LGR segments of 8 points,
then each next segment count with the breaks of `split_breaks` by the judge's
`refinement_error` of the previous solution (the energy family's refinement, here by hand:
the fuel family aligns its breaks with the switches instead). Per mesh: the status (after the
judge), delta-v, each continuation step's status and outer iterations, the violations between
the nodes and the error estimate. Each line is printed as it is solved.

    python experiments/approach_fuel_meshes.py                       # the case's options
    python experiments/approach_fuel_meshes.py --rho-max 1e8 --max-outer 60
"""

import argparse
import dataclasses
import time

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

from jaxlpm.cases import approach  # noqa: E402
from jaxlpm.collocation.segments import segmented_mesh, uniform_breaks  # noqa: E402
from jaxlpm.solution import Judge  # noqa: E402
from jaxlpm.solvers import fuel_optimal  # noqa: E402
from jaxlpm.solvers.refine import split_breaks  # noqa: E402
from jaxlpm.status import Status  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--segments", default="16,24,32,48", help="segment counts, coarsest first")
    ap.add_argument("--points", type=int, default=approach.FUEL_POINTS)
    ap.add_argument("--scheme", default="LGR", choices=("LGR", "LG"))
    ap.add_argument("--rho-max", type=float, default=None, help="the penalty's cap")
    ap.add_argument("--max-outer", type=int, default=None)
    ap.add_argument("--tol-path", type=float, default=None, help="the path tolerance")
    ap.add_argument("--inner", type=int, default=None, help="Newton iterations a subproblem")
    ap.add_argument("--eps", default=None, help="the continuation's schedule, e.g. 1,0.3,0.1")
    args = ap.parse_args(argv)
    al = approach.FUEL_OPTIONS.al
    al = dataclasses.replace(al, rho_max=args.rho_max or al.rho_max,
                             max_outer=args.max_outer or al.max_outer,
                             tol_path=args.tol_path or al.tol_path,
                             inner=dataclasses.replace(
                                 al.inner, max_iterations=args.inner or al.inner.max_iterations))
    options = dataclasses.replace(approach.FUEL_OPTIONS, al=al)
    if args.eps:
        options = dataclasses.replace(options, eps=tuple(float(v) for v in args.eps.split(",")))
    _, fuel = approach.problems()
    judge, sol = Judge(), None
    names = approach.CONSTRAINT_NAMES + ("thrust_bound",)
    for k in (int(v) for v in args.segments.split(",")):
        if sol is None:
            breaks = uniform_breaks(0.0, 1.0, k)
        else:           # the solution's breaks are in tau on [-1, 1]; the mesh's fractions
            tau = split_breaks(np.asarray(sol.grid.breaks), judge.refinement_error(sol), k)
            breaks = 0.5 * (tau + 1.0)
        t = time.perf_counter()
        sol = judge(fuel_optimal.run(fuel, segmented_mesh(breaks, args.points, args.scheme),
                                     "augmented-lagrangian", options))
        st = sol.stats
        steps = ", ".join(f"{Status(int(s)).name} ({int(o)})" for s, o in
                          zip(np.asarray(st["status_by_eps"]), np.asarray(st["outer_by_eps"])))
        violations = ", ".join(f"{n} {v:.1e}" for n, v in
                               zip(names, np.asarray(st["constraint_violation"])))
        print(f"{k} x {args.points} {args.scheme}: {Status(int(sol.status)).name}, delta-v "
              f"{float(sol.cost):.6f} m/s, estimate {float(st['error_position']):.1e} m, "
              f"thrust excess {float(st['path_violation']):.1e} m/s; by eps (outer "
              f"iterations): {steps}; violations: {violations} "
              f"({time.perf_counter() - t:.1f} s)", flush=True)


if __name__ == "__main__":
    main()
