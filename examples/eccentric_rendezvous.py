"""An eccentric rendezvous planned on the linear model, then on the J2 model, both flown on J2.

Mei 2010's chaser (10 km radial and along-track, LVLH) to the chief at rest in 3 periods of an
e = 0.3 orbit. The linear plan (Mei's KKT law) misses when flown with J2 acting on both
spacecraft; the J2 plan (Newton-KKT on the exact J2 relative model) arrives.

    python examples/eccentric_rendezvous.py [--points 65]
"""

import argparse

import jax
import jax.numpy as jnp

jax.config.update("jax_enable_x64", True)
import jaxlpm as lpm  # noqa: E402


def main(points: int = 65):
    deg = jnp.pi / 180.0
    orbit = lpm.KeplerOrbit(a=9500e3, e=0.3, i=30 * deg, raan=30 * deg, argp=10 * deg)
    x0 = jnp.array([10e3, 10e3, 0.0, 4.0, -23.485, 0.0])          # LVLH: m, m/s
    linear = lpm.EnergyOptimalTransfer.from_revolutions(orbit, x0, jnp.zeros(6), 3.0)
    grid = lpm.lgl(points)                                       # points, not degree
    plans = {"linear plan": lpm.solve(linear, grid, throw=False),  # Mei 2010's KKT law
             "J2 plan": lpm.solve(linear.replace(model="j2"), grid, method="newton",
                                  throw=False)}     # a status (INACCURATE: too coarse), no raise
    for name, sol in plans.items():
        miss = lpm.verify.fly(sol, model="j2").terminal_error    # flown with J2 on both
        print(f"{name:12} {sol.message[:9]}  1/2 int |u|^2 dt = {float(sol.cost):.6e} m^2/s^3,"
              f" dv = {float(sol.delta_v):.4f} m/s, miss on J2: {float(miss[0]):.3g} m,"
              f" {float(miss[1]):.3g} m/s")
    return plans


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--points", type=int, default=65, help="LGL points (default 65)")
    main(parser.parse_args().points)
