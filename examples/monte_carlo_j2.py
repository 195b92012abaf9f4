"""Tutorial: a Monte Carlo of re-planned rendezvous on the J2 model, from your own dispersion.

`dispersion(key, n)` is yours: here the chaser's initial LVLH state is scattered about a
nominal approach (N(0, 200 m) per position axis, N(0, 0.2 m/s) per velocity axis) and every
sample must reach the chief at rest in 1.5 periods of a LEO orbit. `replan_monte_carlo`
re-plans each sample by Newton-KKT on the exact J2 relative model (chunked, resumable after
a kill: --out/samples-<n>x<points>/) and returns one row per sample; the statistics and the
histograms take the SUCCESS samples only, the others counted apart. Written to --out:

    histograms.png   delta-v (m/s) and cost (m^2/s^3) over the SUCCESS samples
    dispersion.png   each sample's initial position (y, x) coloured by its delta-v

    python examples/monte_carlo_j2.py [--n 200] [--points 33] [--out DIR]
"""

import argparse
from pathlib import Path

import jax
import jax.numpy as jnp
import matplotlib.pyplot as plt

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


def main(n: int = 200, points: int = 33, out="results/examples/monte_carlo_j2"):
    out = Path(out)
    result = lpm.batch.replan_monte_carlo(jax.random.key(0), n, dispersion, [points],
                                          method="newton", out=out / f"samples-{n}x{points}",
                                          progress=False)
    dv = result.statistics(columns=("delta_v",))[points]["delta_v"]
    print(f"{dv['converged']} of {n} SUCCESS (not: {dv['not_converged']}); delta-v (m/s) "
          f"median {dv['percentiles'][50.0]:.4f}, 5-95 % [{dv['percentiles'][5.0]:.4f}, "
          f"{dv['percentiles'][95.0]:.4f}], mean {dv['mean']:.4f}")

    t = result.tables[points]                                    # one row per sample
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4.4))
    lpm.plot.histogram(t["delta_v"], t["status"], ax=a1, xlabel="delta-v (m/s)")
    lpm.plot.histogram(t["cost"], t["status"], ax=a2, xlabel="1/2 ∫|u|² dt (m²/s³)")
    x0 = t["problem.x0"]                                         # (n, 6) LVLH, m and m/s
    ax = lpm.plot.sweep_map(x0[:, 1], x0[:, 0], t["delta_v"], t["status"],
                            colorbar_label="delta-v (m/s)", xlabel="y0 along-track (m)",
                            ylabel="x0 radial (m)", title="initial positions")
    print("wrote", lpm.plot.save(fig, out / "histograms.png"), "and",
          lpm.plot.save(ax, out / "dispersion.png"))
    return result


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--n", type=int, default=200, help="samples (default 200)")
    parser.add_argument("--points", type=int, default=33, help="LGL points (default 33)")
    parser.add_argument("--out", default="results/examples/monte_carlo_j2",
                        help="folder for the figures and the resumable samples")
    args = parser.parse_args()
    main(args.n, args.points, args.out)
