"""A finite burn solved on its grid padded to 21 points (what a concrete `jaxlpm.solve` runs
since issue 21: one program for lgl(5), lgl(10) and lgl(20)) against the same burn solved on
the grid itself (the finite burn's own program per n), tan2011's intercept with its impulsive
seed given to both.

    PYTHONPATH=. python experiments/finite_burn_padding.py

Prints per n: status, D, Newton iterations and flown-plan numbers of both, and the largest
differences of the nodal states (m), directions and t_s (s). The padding's unknowns are
pinned (`jaxlpm.nlp.transcription`), so the two are the same KKT point up to the solver's
tolerances (inner stationarity 1e-6, |u|^2 - 1 to 1e-7, in scaled units).
"""

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

import jaxlpm  # noqa: E402
from jaxlpm.cases import tan2011  # noqa: E402
from jaxlpm.collocation import lgl  # noqa: E402
from jaxlpm.solvers import finite_burn  # noqa: E402


def main():
    fb = tan2011.finite_burn_problem(tan2011.problem())
    options = finite_burn.FiniteBurnOptions()
    seed = finite_burn._seed(fb)
    for n in (5, 10, 20):
        padded = jaxlpm.solve(fb.replace(seed_time=seed[0], seed_dv=seed[1]), lgl(n))
        own = finite_burn._compiled(fb, lgl(n), options, seed)
        for name, sol in (("padded", padded), ("own grid", own)):
            st = sol.stats
            print(f"lgl({n:2d}) {name:8s} {jaxlpm.Status(int(sol.status)).name:8s} "
                  f"D = {float(sol.cost):.9f} s, t_s = {float(st['t_start']):.6f} s, "
                  f"{int(st['newton_iterations'])} Newton, collocated miss "
                  f"{float(st['miss']):.2e} m, error estimate "
                  f"{float(st['error_position']):.2e} m")
        d = lambda a, b: float(np.max(np.abs(np.asarray(a) - np.asarray(b))))  # noqa: E731
        print(f"          difference: D {d(padded.cost, own.cost):.1e} s, t_s "
              f"{d(padded.stats['t_start'], own.stats['t_start']):.1e} s, states "
              f"{d(padded.node_states, own.node_states):.1e} m, directions "
              f"{d(padded.stats['node_directions'], own.stats['node_directions']):.1e}")


if __name__ == "__main__":
    main()
