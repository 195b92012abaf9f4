"""The error estimate against the flown miss (issue 19): e = 0.6 over 3 revolutions and e = 0.1
over one, on the linear, two-body and J2 models, on grids from unresolved to resolved (lgl(17),
lgl(65), lg(40), 4 x 16 and 16 x 16 LGR segments), each solved by Newton-KKT and flown by
`jaxlpm.verify.fly` (Dopri8, rtol 1e-12) on its own model. Prints the status, the estimate
(error_position m, error_velocity m/s), the relative GPOPS-II estimate and the flown terminal
miss (m, m/s) per row.

    python experiments/accuracy_estimate.py
"""

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

import jaxlpm as lpm  # noqa: E402

GRIDS = {"lgl(17)": lpm.lgl(17), "lgl(65)": lpm.lgl(65), "lg(40)": lpm.lg(40),
         "4 x 16 LGR": lpm.lgr_mesh(4, 16), "16 x 16 LGR": lpm.lgr_mesh(16, 16)}


def main():
    x0 = jnp.array([10e3, 10e3, 0.0, 4.0, -3.0, 0.0])
    print(f"{'e':>4} {'rev':>4} {'model':>9} {'grid':>12} {'status':>11} {'est (m)':>9} "
          f"{'est (m/s)':>9} {'relative':>8} {'flown (m)':>9} {'flown (m/s)':>11}")
    for e, rev in ((0.6, 3.0), (0.1, 1.0)):
        orbit = lpm.KeplerOrbit(a=6978e3 / (1 - e), e=e, i=0.5236, raan=0.5236, argp=0.1745)
        for model in ("linear", "two-body", "j2"):
            problem = lpm.EnergyOptimalTransfer.from_revolutions(orbit, x0, jnp.zeros(6), rev,
                                                                 model=model)
            for name, grid in GRIDS.items():
                sol = lpm.solve(problem, grid, method="newton", throw=False)
                miss = np.asarray(lpm.verify.fly(sol).terminal_error)
                st = sol.stats
                print(f"{e:>4} {rev:>4} {model:>9} {name:>12} {str(lpm.Status(int(sol.status))):>11} "
                      f"{float(st['error_position']):9.2e} {float(st['error_velocity']):9.2e} "
                      f"{float(st['relative_error']):8.1e} {miss[0]:9.2e} {miss[1]:11.2e}")


if __name__ == "__main__":
    main()
