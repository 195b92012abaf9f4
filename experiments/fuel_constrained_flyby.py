"""The cost of the fuel-optimal continuation with a safety constraint (issue 22,
`jaxlpm.solvers.fuel_constrained`): the keep-out flyby of tests/test_fuel_constrained.py
(e = 0.05, linear model, 1500 m sphere, 0.5 N on 100 kg) on 16 LGR segments of 8 points.
Prints, per eps of the schedule, the status, the delta-v and the Newton and outer iterations,
then the total time of the call (compile included) and the unconstrained fuel optimum of the
same mesh (the condensed homotopy).

    python experiments/fuel_constrained_flyby.py
"""

import sys
import time
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from test_fuel_constrained import flyby  # noqa: E402

import jaxlpm as lpm  # noqa: E402


def main():
    mesh = lpm.segmented_lgr(lpm.uniform_breaks(0.0, 1.0, 16), 8)
    t = time.perf_counter()
    sol = jax.block_until_ready(lpm.solve(flyby(1500.0), mesh, throw=False))
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
