"""Tutorial: an eccentric rendezvous planned on the linear model, then on the J2 model, both
flown on J2, plotted and exported as a CCSDS ephemeris.

Mei 2010's chaser starts 10 km above and 10 km ahead of the chief (LVLH: x radial, y
along-track) and must reach it at rest in 3 periods of an e = 0.3 orbit, inclined so that
J2 matters. The linear plan (Mei's KKT law on the Tschauner-Hempel model) misses by
kilometres when its control is flown with J2 acting on both spacecraft; the J2 plan
(Newton-KKT on the exact J2 relative model) arrives. Written to --out:

    trajectory.png   both plans flown on J2, in the LVLH planes y-x and y-z
    controls.png     the J2 plan's control: u_x, u_y, u_z and |u| against time
    deputy_j2.oem    the J2 plan's deputy ephemeris (CCSDS OEM: EME2000, UTC, km, km/s)

    python examples/eccentric_rendezvous.py [--points 65] [--out DIR]
"""

import argparse
from pathlib import Path

import jax
import jax.numpy as jnp

jax.config.update("jax_enable_x64", True)
import jaxlpm as lpm  # noqa: E402

EPOCH = "2026-03-01T12:00:00"                                    # UTC at t = 0, for the OEM


def main(points: int = 65, out="results/examples/eccentric_rendezvous"):
    deg = jnp.pi / 180.0
    orbit = lpm.KeplerOrbit(a=9500e3, e=0.3, i=30 * deg, raan=30 * deg, argp=10 * deg)
    x0 = jnp.array([10e3, 10e3, 0.0, 4.0, -23.485, 0.0])          # LVLH: m, m/s
    linear = lpm.EnergyOptimalTransfer.from_revolutions(orbit, x0, jnp.zeros(6), 3.0)
    grid = lpm.lgl(points)                                       # points, not degree
    plans = {"linear plan": lpm.solve(linear, grid, throw=False),  # Mei 2010's KKT law
             "J2 plan": lpm.solve(linear.replace(model="j2"), grid, method="newton",
                                  throw=False)}     # a status (INACCURATE if too coarse), no raise
    axes = None                                                  # one figure for both flights
    for name, sol in plans.items():
        flight = lpm.verify.fly(sol, model="j2")                 # flown with J2 on both
        miss = flight.terminal_error
        print(f"{name:12} {lpm.Status(int(sol.status))!s:10}  1/2 int |u|^2 dt = "
              f"{float(sol.cost):.6e} m^2/s^3, dv = {float(sol.delta_v):.4f} m/s, error "
              f"estimate {float(sol.stats['error_position']):.3g} m, miss on J2: "
              f"{float(miss[0]):.3g} m, {float(miss[1]):.3g} m/s")
        axes = lpm.plot.trajectory(flight, ax=axes, label=f"{name}, flown on J2")
    out = Path(out)
    written = [lpm.plot.save(axes, out / "trajectory.png"),
               lpm.plot.save(lpm.plot.controls(plans["J2 plan"], title="J2 plan"),
                             out / "controls.png"),
               lpm.io.write_oem(plans["J2 plan"], out / "deputy_j2.oem", EPOCH)]
    print("wrote", ", ".join(str(p) for p in written))
    return plans


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--points", type=int, default=65, help="LGL points (default 65)")
    parser.add_argument("--out", default="results/examples/eccentric_rendezvous",
                        help="folder for the figures and the OEM")
    args = parser.parse_args()
    main(args.points, args.out)
