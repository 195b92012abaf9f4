"""Cost of mei2010's rendezvous over (e, duration), and its convergence with the grid (issue 8).

One resumable sweep (`jaxlpm.batch.sweep`, the KKT or STM law on the linear model) of
mei2010's transfer over e x revolutions x grid size (lgl(points)), the chief's perigee radius
held (a = r_p / (1 - e), r_p = 9500 km x (1 - 0.3) = 6650 km, mei2010's chief), then two PNGs:
  sweep_heatmap.png      log10 of the energy cost 1/2 int |u|^2 dt (m^2/s^3) over (e,
                         revolutions) on the largest grid; non-converged members drawn blank
  sweep_convergence.png  per grid size n (points): max and median over the members of
                         |J_n - J_nmax| / J_nmax, and the fraction converged
and sweep_summary.json beside them. Re-running the same command resumes the sweep.

Run:  python experiments/sweep_heatmap.py --e 0:0.6:31 --revolutions 1:5:17 --points 9,17,33,65 \
          --method kkt --out results/sweep_heatmap
"""

import argparse
import json
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from jaxlpm.batch import parameter_grid, sweep, transfer_family  # noqa: E402
from jaxlpm.cases import mei2010  # noqa: E402
from jaxlpm.cli import _setup_jax, _values  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--e", type=_values, default=_values("0:0.6:31"))
    ap.add_argument("--revolutions", type=_values, default=_values("1:5:17"))
    ap.add_argument("--points", type=lambda t: _values(t, integer=True),
                    default=_values("9,17,33,65", integer=True),
                    help="grid sizes lgl(points) (Mei 2010's degree N is points - 1)")
    ap.add_argument("--method", default="kkt", choices=("kkt", "stm"))
    ap.add_argument("--chunk", type=int, default=256)
    ap.add_argument("--out", default="results/sweep_heatmap")
    args = ap.parse_args(argv)
    print(f"compilation cache: {_setup_jax()}")
    out = Path(args.out)
    family = transfer_family("mei2010", mei2010.problem(), args.method, hold="perigee")
    result = sweep(family, parameter_grid(e=args.e, revolutions=args.revolutions), args.points,
                   out / "sweep", chunk_size=args.chunk)
    shape = (len(args.e), len(args.revolutions))
    top = max(args.points)
    ok = {n: (t["status"] == 0).reshape(shape) for n, t in result.tables.items()}
    cost = {n: np.where(ok[n], t["cost"].reshape(shape), np.nan)
            for n, t in result.tables.items()}

    fig, ax = plt.subplots(figsize=(7, 4.5))
    im = ax.pcolormesh(args.revolutions, args.e, np.log10(cost[top]), shading="nearest")
    fig.colorbar(im, label=r"log$_{10}$ ½∫|u|²dt  (m²/s³)")
    ax.set(xlabel="duration (chief revolutions)", ylabel="chief eccentricity e",
           title=f"mei2010 rendezvous, {args.method.upper()} law, lgl({top}) "
                 f"(perigee radius held)")
    fig.tight_layout()
    fig.savefig(out / "sweep_heatmap.png", dpi=150)

    rows = []
    for n in sorted(result.tables):
        rel = np.abs(cost[n] - cost[top]) / cost[top]
        rows.append(dict(points=n, converged=int(ok[n].sum()), members=int(ok[n].size),
                         max_rel_diff=float(np.nanmax(rel)),
                         median_rel_diff=float(np.nanmedian(rel))))
    fig, ax = plt.subplots(figsize=(6, 4))
    sizes = [r["points"] for r in rows[:-1]]
    ax.semilogy(sizes, [r["max_rel_diff"] for r in rows[:-1]], "o-", label="max over the members")
    ax.semilogy(sizes, [r["median_rel_diff"] for r in rows[:-1]], "s-", label="median")
    ax.set(xlabel="points n (grid lgl(n))", ylabel=f"|J_n − J_{top}| / J_{top}",
           title="convergence of the optimal cost with the grid")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "sweep_convergence.png", dpi=150)
    summary = dict(method=args.method, held="perigee radius", e=args.e,
                   revolutions=args.revolutions, convergence=rows, converged=result.summary())
    (out / "sweep_summary.json").write_text(
        json.dumps(summary, indent=2, default=lambda x: np.asarray(x).tolist()))
    for r in rows:
        print(f"{r['points']:>4} points: {r['converged']}/{r['members']} converged; cost vs "
              f"{top} points: max rel diff {r['max_rel_diff']:.2e}, median "
              f"{r['median_rel_diff']:.2e}")
    print(f"wrote {out}/sweep_heatmap.png, sweep_convergence.png, sweep_summary.json")


if __name__ == "__main__":
    main()
