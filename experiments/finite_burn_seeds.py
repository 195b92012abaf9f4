"""tan2011's minimum-duration finite burn from seeds a round-off apart: the impulsive seed's
delta-v scaled by (1 + k 1e-11), k = 0..K-1, on lgl(5), lgl(10) and lgl(20). Prints per grid
the statuses, t_s steps, augmented-Lagrangian solves and Newton iterations, and the spread of
the burn start t_s (s) and duration D (s) over the seeds that succeeded. A solve whose path
depends on round-off shows as different counts; one that fails on it, as a status other than
SUCCESS.

    python experiments/finite_burn_seeds.py [--seeds 8]
"""

import argparse
import dataclasses

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

import jaxlpm as lpm  # noqa: E402
from jaxlpm.cases import tan2011  # noqa: E402
from jaxlpm.status import Status  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=8)
    args = parser.parse_args()
    elements, _ = tan2011.recover_elements()
    intercept = tan2011.problem(elements)
    impulse = lpm.solve(intercept)
    burn = tan2011.finite_burn_problem(intercept)
    t_burn, dv = impulse.stats["t_burn"], impulse.stats["dv"]
    for n in tan2011.NODES:
        rows = []
        for k in range(args.seeds):
            seeded = dataclasses.replace(burn, seed_time=t_burn, seed_dv=dv * (1 + k * 1e-11))
            sol = lpm.solve(seeded, lpm.lgl(n), throw=False)
            st = sol.stats
            rows.append((Status(int(sol.status)).name, int(st["search_iterations"]),
                         int(st["arc_solves"]), int(st["newton_iterations"]),
                         float(st["t_start"]), float(sol.cost)))
        ok = [r for r in rows if r[0] == "SUCCESS"]
        print(f"lgl({n}): {len(ok)} / {len(rows)} SUCCESS; (t_s steps, AL solves, Newton) "
              f"{[r[1:4] for r in rows]}; other statuses {[r[0] for r in rows if r not in ok]}")
        if ok:
            t_s, duration = np.array([r[4] for r in ok]), np.array([r[5] for r in ok])
            print(f"  spread over the seeds: t_s {np.ptp(t_s):.2e} s, D {np.ptp(duration):.2e} s")


if __name__ == "__main__":
    main()
