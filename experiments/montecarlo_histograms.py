"""Monte Carlo histograms (issue 8), both kinds, reproducible from --seed.

(a) re-plan: --replan samples of mei2010's dispersion (`jaxlpm.cases.mei2010.dispersion`, on
    the model of --method) solved on lgl(--points) by --method (kkt: the linear law, linear
    model; newton: Newton-KKT on the two-body model), resumable under --out/replan;
    histograms of the cost and delta-v of the converged samples, convergence counts.
(b) execution: mei2010's plan (lgl(--points), --method) flown --fly times through the
    two-body model with execution errors (--magnitude relative, --direction rad, --position m,
    --velocity m/s, one sigma); histograms of the terminal position and velocity miss.

Writes montecarlo_replan.png, montecarlo_execution.png and montecarlo_summary.json.

Run:  python experiments/montecarlo_histograms.py --replan 1000 --fly 1000 --points 65 \
          --method kkt --seed 0 --out results/montecarlo
"""

import argparse
import functools
import json
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

import matplotlib  # noqa: E402

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from jaxlpm import lgl, solve  # noqa: E402
from jaxlpm.batch import ExecutionErrors, execution_monte_carlo, replan_monte_carlo  # noqa: E402
from jaxlpm.cases import mei2010  # noqa: E402
from jaxlpm.cli import _setup_jax  # noqa: E402

MODEL = {"kkt": "linear", "newton": "two-body"}


def histograms(path, panels, title):
    fig, axes = plt.subplots(1, len(panels), figsize=(5 * len(panels), 3.8))
    for ax, (values, label) in zip(np.atleast_1d(axes), panels):
        ax.hist(values, bins=40)
        ax.set(xlabel=label, ylabel="samples")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=150)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--replan", type=int, default=1000)
    ap.add_argument("--fly", type=int, default=1000)
    ap.add_argument("--points", type=int, default=65,
                    help="grid lgl(points) (default 65: Mei 2010's N = 64)")
    ap.add_argument("--method", default="kkt", choices=("kkt", "newton"))
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--magnitude", type=float, default=0.01)
    ap.add_argument("--direction", type=float, default=1e-3)
    ap.add_argument("--position", type=float, default=10.0)
    ap.add_argument("--velocity", type=float, default=0.01)
    ap.add_argument("--chunk", type=int, default=250)
    ap.add_argument("--out", default="results/montecarlo")
    args = ap.parse_args(argv)
    print(f"compilation cache: {_setup_jax()}")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    key_replan, key_fly = jax.random.split(jax.random.key(args.seed))
    summary = dict(seed=args.seed, points=args.points, method=args.method)
    model = MODEL[args.method]

    if args.replan:
        r = replan_monte_carlo(key_replan, args.replan,
                               functools.partial(mei2010.dispersion, model=model),
                               [args.points], method=args.method, out=out / "replan",
                               chunk_size=min(args.chunk, args.replan))
        t, stats = r.tables[args.points], r.statistics()[args.points]
        ok = t["status"] == 0
        summary["replan"] = dict(samples=args.replan, summary=r.summary()[str(args.points)],
                                 statistics=stats)
        histograms(out / "montecarlo_replan.png",
                   [(np.log10(t["cost"][ok]), r"log$_{10}$ ½∫|u|²dt (m²/s³)"),
                    (t["delta_v"][ok], "Δv = ∫|u|dt (m/s)")],
                   f"re-planned dispersed transfers: {int(ok.sum())}/{args.replan} converged "
                   f"({args.method}, {model} model, lgl({args.points}))")
        print(f"(a) re-plan: {int(ok.sum())}/{args.replan} converged; delta-v median "
              f"{stats['delta_v']['percentiles'][50.0]:.4g} m/s, 5-95 % "
              f"[{stats['delta_v']['percentiles'][5.0]:.4g}, "
              f"{stats['delta_v']['percentiles'][95.0]:.4g}]")

    if args.fly:
        problem = mei2010.problem().replace(model=model)
        plan = solve(problem, lgl(args.points), method=args.method)
        errors = ExecutionErrors(args.magnitude, args.direction, args.position, args.velocity)
        r = execution_monte_carlo(key_fly, plan, args.fly, errors, model="two-body")
        ok = r["status"] == 0
        summary["execution"] = dict(samples=args.fly, errors=errors.__dict__,
                                    nominal_miss=r["nominal"], integrated=int(ok.sum()),
                                    statistics=r["statistics"])
        histograms(out / "montecarlo_execution.png",
                   [(r["position_miss"][ok], "terminal position miss (m)"),
                    (r["velocity_miss"][ok], "terminal velocity miss (m/s)")],
                   f"mei2010 plan ({args.method}, lgl({args.points})) flown on the two-body model; "
                   f"error-free miss {r['nominal'][0]:.3g} m")
        s = r["statistics"]["position_miss"]
        print(f"(b) execution: error-free miss {r['nominal'][0]:.4g} m, "
              f"{r['nominal'][1]:.4g} m/s; with errors median {s['percentiles'][50.0]:.4g} m, "
              f"95 % {s['percentiles'][95.0]:.4g} m ({int(ok.sum())}/{args.fly} integrated)")

    (out / "montecarlo_summary.json").write_text(
        json.dumps(summary, indent=2, default=lambda x: np.asarray(x).tolist()))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
