"""A Monte Carlo of re-planned rendezvous on the J2 model, from the user's own dispersion:
chaser states scattered about a nominal approach, each re-planned by Newton-KKT on the exact
J2 relative model; delta-v statistics over the SUCCESS samples (the others counted apart).

    python examples/monte_carlo_j2.py [--n 200] [--points 33] [--out results/mc_j2]
"""

import argparse

import jax
import jax.numpy as jnp

jax.config.update("jax_enable_x64", True)
import jaxlpm as lpm  # noqa: E402

ORBIT = lpm.KeplerOrbit(a=7200e3, e=0.05, i=0.9, raan=0.5)       # a LEO chief (m, rad)
NOMINAL = jnp.array([-2000.0, -8000.0, 300.0, 0.0, 3.5, 0.0])    # LVLH: m, m/s


def dispersion(key, n):
    """x0 = NOMINAL + N(0, 200 m) per position axis, N(0, 0.2 m/s) per velocity axis, to the
    chief at rest in 1.5 periods: one batched problem (leading axis n)."""
    dr, dv = jax.random.normal(key, (2, n, 3)) * jnp.array([200.0, 0.2])[:, None, None]
    return jax.vmap(lambda d: lpm.EnergyOptimalTransfer.from_revolutions(
        ORBIT, NOMINAL + d, jnp.zeros(6), 1.5, model="j2"))(jnp.concatenate([dr, dv], 1))


def main(n: int = 200, points: int = 33, out=None):
    result = lpm.batch.replan_monte_carlo(jax.random.key(0), n, dispersion, [points],
                                          method="newton", out=out, progress=False)
    dv = result.statistics(columns=("delta_v",))[points]["delta_v"]
    print(f"{dv['converged']} of {n} SUCCESS (not: {dv['not_converged']}); delta-v (m/s) "
          f"median {dv['percentiles'][50.0]:.4f}, 5-95 % [{dv['percentiles'][5.0]:.4f}, "
          f"{dv['percentiles'][95.0]:.4f}], mean {dv['mean']:.4f}")
    return result


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--n", type=int, default=200, help="samples (default 200)")
    parser.add_argument("--points", type=int, default=33, help="LGL points (default 33)")
    parser.add_argument("--out", help="directory for the resumable results (default: none)")
    args = parser.parse_args()
    main(args.n, args.points, args.out)
