"""The finite burn's error estimate against its flight as the degree of its LGL grid grows
(issue 19: the burn is one smooth arc, so `solve(problem)` without a grid raises its degree,
`jaxlpm.solvers.finite_burn.refine_degree`), on tan2011's intercept (recovered elements, 3
revolutions, left branch: tests/test_tan2011.py's burn).

    PYTHONPATH=. python experiments/finite_burn_degrees.py [--points 3,4,5,9,13,21]

Prints per grid: status at the default tolerance, the burn time D, the estimate (position,
velocity), the solver's own coast miss, the terminal miss of the solution flown by
`jaxlpm.verify.fly` (Dopri8 from t = 0 through the burn, J2), and the solve's wall time (the
first includes compiling the padded program every grid up to 21 points shares).
"""

import argparse
import time

import jax

jax.config.update("jax_enable_x64", True)

import jaxlpm as lpm  # noqa: E402
from jaxlpm.cases import tan2011  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--points", default="3,4,5,9,13,21")
    args = ap.parse_args(argv)
    elements, _ = tan2011.recover_elements()
    fb = tan2011.finite_burn_problem(tan2011.problem(elements, revolutions=3, branch="left"))
    for n in (int(p) for p in args.points.split(",")):
        t = time.perf_counter()
        sol = lpm.solve(fb, lpm.lgl(n), throw=False)
        seconds = time.perf_counter() - t
        st = sol.stats
        flown = lpm.verify.fly(sol).terminal_error
        print(f"lgl({n:2d}): {lpm.Status(int(sol.status)).name:14s} D = {float(sol.cost):.6f} s,"
              f" estimate {float(st['error_position']):.2e} m, "
              f"{float(st['error_velocity']):.2e} m/s, coast miss {float(st['miss']):.2e} m, "
              f"flown {float(flown[0]):.2e} m ({seconds:.1f} s)", flush=True)


if __name__ == "__main__":
    main()
