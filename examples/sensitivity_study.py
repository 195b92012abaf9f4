"""Sensitivity of the energy-optimal transfer cost to the chief's eccentricity and the transfer
duration over a 10 x 10 grid of cases: one vmapped, differentiated solve (implicit gradients).

    python examples/sensitivity_study.py [--n 10] [--points 33]
"""

import argparse

import jax
import jax.numpy as jnp

jax.config.update("jax_enable_x64", True)
import jaxlpm as lpm  # noqa: E402


def main(n: int = 10, points: int = 33):
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
    return e, rev, J, dJ_de, dJ_drev, status


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--n", type=int, default=10, help="values of e and of the duration")
    parser.add_argument("--points", type=int, default=33, help="LGL points (default 33)")
    args = parser.parse_args()
    main(args.n, args.points)
