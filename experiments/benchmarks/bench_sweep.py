"""Benchmark of the sweep engine (issue 8): LQ-law sweep throughput against CasADi + IPOPT one
problem at a time, and the two Monte Carlo kinds on the nonlinear model.

1. LQ laws through `jaxlpm.batch.sweep` (chunked lax.map, sharded over the local devices,
   written to disk as it goes): mei2010's transfer (a = 9500 km held, as bench_lq_laws.py),
   e = linspace(0, 0.3, --members), grid lgl(--points); compile time and solves/s
   (a) in the chunks: the sweep's own per-chunk log, the compiled call until its results are
   NumPy arrays on the host; (b) over the whole sweep less its compile time: placing the
   chunks on the devices, writing the .npz files and the manifest included.
2. Peer: the same collocated QP in CasADi + IPOPT (bench_lq_laws.build_ipopt, its data from
   jaxlpm's own prelude), solved one problem at a time on --n-peer of the members.
3. Monte Carlo on the two-body model, from jax.random.key(--seed):
   (a) --mc-replan samples of mei2010's dispersion (`jaxlpm.cases.mei2010.dispersion`,
       two-body) re-planned by Newton-KKT on lgl(--mc-points): wall time and the fraction
       converged;
   (b) mei2010's KKT plan (lgl(--mc-points)) flown --mc-fly times with execution errors (1 %
       thrust magnitude, 1 mrad direction, 10 m / 1 cm/s navigation): wall time, misses.
Ratios are reported against the issue's goals (STM >= 2000x, KKT >= 10x IPOPT; 10^4 nonlinear
samples in < 10 min, >= 99.9 % converged).

Run (the numbers in experiments/README.md come from the command written there):
  PYTHONPATH=. python experiments/benchmarks/bench_sweep.py --members 1024 --points 65 \
      --out results/bench_sweep
"""

import argparse
import json
import os
import shutil
import statistics
import sys
import time
from pathlib import Path

# jaxlpm first: its CPU runtime settings before numpy/scipy/casadi (see bench_lq_laws)
from jaxlpm import lgl, solve

import jax  # noqa: E402

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

from jaxlpm.batch import (ExecutionErrors, execution_monte_carlo, load_sweep,  # noqa: E402
                          replan_monte_carlo, sweep, transfer_family)
from jaxlpm.cases import mei2010  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_lq_laws import GOALS, build_ipopt, make_batch, th_cost, th_data  # noqa: E402
from common import machine_info  # noqa: E402

E_MAX = 0.3          # a = 9500 km held: perigee above the ground (bench_lq_laws goes to 0.5)


def lq_sweep(method, es, points, chunk, out):
    """The sweep (fresh directory); compile and per-chunk compute times from its manifest."""
    if out.exists():
        shutil.rmtree(out)
    fam = transfer_family("bench", mei2010.problem(), method, hold="a")
    t0 = time.perf_counter()
    result = sweep(fam, dict(e=es), [points], out, chunk_size=chunk, progress=False)
    wall = time.perf_counter() - t0
    m = json.loads((out / "manifest.json").read_text())
    compile_s = sum(c["seconds"] for c in m["compiles"])
    compute = [c["seconds"] for c in m["chunks"].values()]
    t = result.tables[points]
    return dict(method=method, members=len(es), points=points, chunk=chunk, compile_s=compile_s,
                chunks=len(compute), chunk_median_s=statistics.median(compute),
                compute_s=sum(compute), solves_per_s=len(es) / sum(compute),
                wall_s=wall, wall_solves_per_s=len(es) / (wall - compile_s),
                converged=int(np.sum(t["status"] == 0))), t


def ipopt_peer(es, points, members, costs_kkt):
    """IPOPT on the same discrete QP, one problem at a time (bench_lq_laws' formulation)."""
    grid = lgl(points)
    D, w = np.asarray(grid.D), np.asarray(grid.weights)
    data = th_data(make_batch(es[members]), grid)
    solver, nvar, _ = build_ipopt(D, w)
    times, rel, status = [], [], []
    n = D.shape[0]
    for j, i in enumerate(members):
        p = np.concatenate([data["rho"][j], [data["half"][j]], data["X0"][j], data["XT"][j]])
        t0 = time.perf_counter()
        out = solver(x0=np.zeros(nvar), p=p, lbg=0.0, ubg=0.0)
        times.append(time.perf_counter() - t0)
        z = np.asarray(out["x"]).ravel()
        U = z[6 * n:9 * n].reshape(3, n).T
        cost = th_cost(U, w, data["rho"][j], data["half"][j]) * data["k2"][j] ** 4
        rel.append(abs(cost - costs_kkt[i]) / abs(costs_kkt[i]))
        status.append(solver.stats()["return_status"])
    return dict(problems=len(members), median_s=statistics.median(times),
                solves_per_s=1.0 / statistics.median(times), cost_rel_diff_vs_kkt_max=max(rel),
                return_status=sorted(set(status)))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--members", type=int, default=1024)
    ap.add_argument("--points", type=int, default=65, help="grid lgl(points) (65: N = 64)")
    ap.add_argument("--chunk", type=int, default=256)
    ap.add_argument("--n-peer", type=int, default=20)
    ap.add_argument("--mc-replan", type=int, default=0, help="Monte Carlo (a) samples")
    ap.add_argument("--mc-fly", type=int, default=0, help="Monte Carlo (b) samples")
    ap.add_argument("--mc-points", type=int, default=65, help="Monte Carlo grids lgl(points)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default="results/bench_sweep")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    cache = os.environ.get("JAXLPM_CACHE_DIR")
    if cache:
        jax.config.update("jax_compilation_cache_dir", cache)
    res = dict(machine=machine_info(), argv=sys.argv, devices=jax.local_device_count(),
               persistent_cache=cache)
    es = np.linspace(0.0, E_MAX, args.members)
    tables = {}
    for method in ("stm", "kkt"):
        res[method], tables[method] = lq_sweep(method, es, args.points, args.chunk,
                                               out / f"sweep_{method}")
        print(f"[{method}] {res[method]['solves_per_s']:.0f} solves/s in the chunks "
              f"({res[method]['wall_solves_per_s']:.0f} with transfers and writes), compile "
              f"{res[method]['compile_s']:.1f} s, {res[method]['converged']}/{args.members} "
              f"converged", flush=True)
    members = np.unique(np.linspace(0, args.members - 1, args.n_peer).round().astype(int))
    res["ipopt"] = ipopt_peer(es, args.points, members, tables["kkt"]["cost_true_anomaly"])
    print(f"[ipopt] {res['ipopt']['solves_per_s']:.1f} solves/s, cost rel diff vs kkt max "
          f"{res['ipopt']['cost_rel_diff_vs_kkt_max']:.1e}", flush=True)
    for method in ("stm", "kkt"):
        ratio = res[method]["solves_per_s"] / res["ipopt"]["solves_per_s"]
        res[method].update(vs_ipopt=ratio, goal=GOALS[method],
                           goal_met=bool(ratio >= GOALS[method]))
        print(f"[{method}] {ratio:.0f}x IPOPT (goal {GOALS[method]:.0f}x)")
    key = jax.random.key(args.seed)
    if args.mc_replan:
        t0 = time.perf_counter()
        r = replan_monte_carlo(key, args.mc_replan, mei2010.dispersion, [args.mc_points],
                               method="newton", out=out / "mc_replan",
                               chunk_size=min(50, args.mc_replan), batch_size=1, progress=False)
        wall = time.perf_counter() - t0
        s = r.summary()[str(args.mc_points)]
        res["mc_replan"] = dict(samples=args.mc_replan, points=args.mc_points, wall_s=wall,
                                converged=s["converged"],
                                converged_fraction=s["converged"] / args.mc_replan,
                                status_counts=s["status_counts"],
                                statistics=r.statistics()[args.mc_points])
        print(f"[mc replan] {args.mc_replan} samples in {wall:.1f} s, "
              f"{s['converged']}/{args.mc_replan} converged", flush=True)
    if args.mc_fly:
        plan = solve(mei2010.problem(), lgl(args.mc_points), method="kkt")
        errors = ExecutionErrors(magnitude=0.01, direction=1e-3, position=10.0, velocity=0.01)
        t0 = time.perf_counter()
        r = execution_monte_carlo(key, plan, args.mc_fly, errors, model="two-body")
        wall = time.perf_counter() - t0
        res["mc_fly"] = dict(samples=args.mc_fly, points=args.mc_points, wall_s=wall,
                             errors=errors.__dict__, nominal_miss=r["nominal"],
                             succeeded=int(np.sum(r["status"] == 0)),
                             statistics=r["statistics"])
        print(f"[mc fly] {args.mc_fly} flights in {wall:.1f} s (compile included), "
              f"{res['mc_fly']['succeeded']} integrated", flush=True)
    path = out / "bench_sweep.json"
    path.write_text(json.dumps(res, indent=2, default=lambda x: np.asarray(x).tolist()))
    print(f"wrote {path}")
    assert load_sweep(out / "sweep_kkt").tables[args.points]["index"].size == args.members


if __name__ == "__main__":
    main()
