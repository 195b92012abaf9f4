"""Tutorial: how the optimal cost depends on the chief's eccentricity and on the transfer
duration, over a 10 x 10 grid of cases (100 transfers), with its gradients, in one call.

Each case is Mei 2010's rendezvous (10 km above and ahead of the chief, to the chief at rest)
at one eccentricity e (perigee radius held at 6650 km) and one duration (in chief periods).
`jax.vmap` solves all cases at once and `jax.value_and_grad` differentiates the cost
J = 1/2 int |u|^2 dt (m^2/s^3) with respect to both parameters (Mei's KKT law is a linear
solve, differentiated exactly). A case whose status is not SUCCESS (INACCURATE: too few points
for a very eccentric, long transfer) is greyed out of the maps, not coloured. Written to --out:

    maps.png   J (log colour scale), dJ/de and dJ/d(periods) over (e, periods)

    python examples/sensitivity_study.py [--n 10] [--points 65] [--out DIR]
"""

import argparse
from pathlib import Path

import jax
import jax.numpy as jnp
import matplotlib.pyplot as plt

jax.config.update("jax_enable_x64", True)
import jaxlpm as lpm  # noqa: E402


def main(n: int = 10, points: int = 65, out="results/examples/sensitivity_study"):
    r_p = 6650e3                                                 # perigee radius held (m)
    x0 = jnp.array([10e3, 10e3, 0.0, 4.0, -23.485, 0.0])          # LVLH: m, m/s

    def cost(e, revolutions):                                    # one case; status as aux
        o = lpm.KeplerOrbit(a=r_p / (1.0 - e), e=e)
        prob = lpm.EnergyOptimalTransfer(o, x0, jnp.zeros(6), revolutions * o.period)
        sol = lpm.solve(prob, lpm.lgl(points), throw=False)      # Mei 2010's KKT law
        return sol.cost, sol.status

    e, rev = (g.ravel() for g in jnp.meshgrid(jnp.linspace(0.0, 0.6, n), jnp.linspace(1, 4, n)))
    study = jax.jit(jax.vmap(jax.value_and_grad(cost, argnums=(0, 1), has_aux=True)))
    (J, status), (dJ_de, dJ_drev) = study(e, rev)
    ok = status == lpm.Status.SUCCESS
    print(f"{int(ok.sum())} of {e.size} cases SUCCESS; J = 1/2 int |u|^2 dt (m^2/s^3)")
    for k in jnp.argsort(J)[:: max(1, e.size // 8)]:
        print(f"e = {float(e[k]):.3f}, {float(rev[k]):.2f} periods: J = {float(J[k]):.4e}, "
              f"dJ/de = {float(dJ_de[k]):+.3e}, dJ/d(periods) = {float(dJ_drev[k]):+.3e}")

    fig, axes = plt.subplots(1, 3, figsize=(16, 4.6))
    for ax, values, name, log in ((axes[0], J, "J (m²/s³)", True),
                                  (axes[1], dJ_de, "dJ/de (m²/s³)", False),
                                  (axes[2], dJ_drev, "dJ/d(periods) (m²/s³)", False)):
        lpm.plot.sweep_map(e, rev, values, status, ax=ax, log=log, colorbar_label=name,
                           xlabel="chief eccentricity e", ylabel="duration (chief periods)")
    print("wrote", lpm.plot.save(fig, Path(out) / "maps.png"))
    return e, rev, J, dJ_de, dJ_drev, status


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--n", type=int, default=10, help="values of e and of the duration")
    parser.add_argument("--points", type=int, default=65, help="LGL points (default 65)")
    parser.add_argument("--out", default="results/examples/sensitivity_study",
                        help="folder for the figure")
    args = parser.parse_args()
    main(args.n, args.points, args.out)
