"""Benchmark of adaptive mesh refinement (issue 19) against CasADi + IPOPT on the final mesh.

1. One long eccentric transfer: the two-body model, e = 0.6 (perigee 600 km), 3 revolutions,
   x0 = [10 km, 10 km, 0, 4, -3, 0] to rest at the chief (tests/test_accuracy.py's case).
   Ours: `jaxlpm.solve(problem)`, the whole `MeshLadder` (every rung's Newton-KKT solve,
   error estimate and split), timed in steady state after a first call that compiles every
   rung. Peer: IPOPT on the final mesh alone (the same `LGRMesh`: the same NLP and size),
   from our warm start for that mesh (`_warm_start`: the linear model's solution), written
   in CasADi by bench_newton.build_ipopt. IPOPT is given the mesh that our refinement had to
   find, so the ratio charges us for the rungs below it.
2. A mixed batch: mei2010's two-body dispersion (e in [0, 0.7], 1-5 revolutions; --members).
   Ours: `jaxlpm.batch.refine.refine_batch` (every member on rung 0, only the INACCURATE
   ones on, one compiled function per rung), steady state (the second call). Peer: IPOPT one
   problem at a time on each member's final mesh (that of `solve(member)`, the same ladder
   member by member), the sum of its solve times (its builds, one per mesh, reported apart).
   Throughput ratio: IPOPT's total solve time over ours; ours runs on one core (one process),
   IPOPT too (one process per problem, sequentially), so the ratio is per core.
3. The same batch through the sweep engine (`jaxlpm.batch.sweep` with points ["refine"], one
   chunk, written to disk): its chunk compute time from the manifest (compiles logged apart),
   against IPOPT's solves as in 2.

Run:  PYTHONPATH=. python experiments/benchmarks/bench_refine.py [--members 32]
      [--out results/bench_refine.json]
"""

import argparse
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, os.path.dirname(__file__))
from bench_newton import (IPOPT_OPTIONS, build_ipopt, compare, host, own_kkt_residuals,  # noqa
                          peer_data)

import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
import casadi as ca  # noqa: E402

import jaxlpm as lpm  # noqa: E402
from jaxlpm.batch import SweepFamily, problem_table, sweep  # noqa: E402
from jaxlpm.batch.refine import refine_batch  # noqa: E402
from jaxlpm.cases import mei2010  # noqa: E402
from common import block, machine_info, timed  # noqa: E402

X0 = jnp.array([10e3, 10e3, 0.0, 4.0, -3.0, 0.0])


def eccentric_problem():
    e = 0.6
    orbit = lpm.KeplerOrbit(a=6978e3 / (1.0 - e), e=e, i=0.5, raan=0.5, argp=0.2, f0=0.3)
    return lpm.EnergyOptimalTransfer.from_revolutions(orbit, X0, jnp.zeros(6), 3.0,
                                                      model="two-body")


def ipopt_on(problem, mesh, repeats=3):
    """IPOPT on `mesh` from our warm start: build time, median solve wall time, result."""
    solver, _, build_s, (nv, nc) = build_ipopt(np.asarray(mesh.D), np.asarray(mesh.weights))
    d = host(peer_data(problem, mesh))
    runs = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = solver(x0=d["z0"], p=d["p"], lbg=0.0, ubg=0.0)
        runs.append(time.perf_counter() - t0)
    st = solver.stats()
    ip = dict(z=np.asarray(out["x"]).ravel(), lam=np.asarray(out["lam_g"]).ravel(),
              f=float(out["f"]), status=st["return_status"], iterations=int(st["iter_count"]))
    return dict(build_s=build_s, solve_median_s=statistics.median(runs), variables=nv,
                constraints=nc, status=ip["status"], iterations=ip["iterations"]), ip, d


def single(res):
    prob = eccentric_problem()
    t0 = time.perf_counter()
    sol = block(lpm.solve(prob))
    first = time.perf_counter() - t0
    run = timed(lambda: block(lpm.solve(prob)), min_repeats=5, budget_s=10.0)
    mesh = sol.grid
    peer, ip, d = ipopt_on(prob, mesh, repeats=5)
    kc, kg = own_kkt_residuals(prob, jnp.asarray(ip["z"]), jnp.asarray(ip["lam"]), mesh)
    res["single"] = dict(
        case="two-body, e 0.6, perigee 600 km, 3 revolutions, x0 [10 km, 10 km, 0, 4, -3, 0]",
        final_mesh=dict(segments=mesh.n_segments, points_per_segment=mesh.segment.n,
                        points=mesh.n, rung=int(sol.stats["rung"])),
        ours=dict(first_call_s=first, steady=run, status=int(sol.status),
                  error_position_m=float(sol.stats["error_position"])),
        ipopt=dict(peer, own_kkt_constraint_residual=float(kc),
                   own_kkt_stationarity_residual=float(kg),
                   agreement=compare(sol.cost, np.asarray(sol.node_controls), ip, d)),
        steady_ratio_ours_over_ipopt=run["median_s"] / peer["solve_median_s"])
    r = res["single"]
    print(f"[single] final mesh {mesh.n_segments} x {mesh.segment.n} (rung "
          f"{r['final_mesh']['rung']}): ours {run['median_s']:.3f} s steady (first call "
          f"{first:.1f} s), IPOPT on the final mesh {peer['solve_median_s']:.3f} s "
          f"({peer['status']}, {peer['iterations']} it, build {peer['build_s']:.1f} s): ratio "
          f"{r['steady_ratio_ours_over_ipopt']:.2f}; cost rel diff "
          f"{r['ipopt']['agreement']['cost_rel_diff']:.1e}", flush=True)


def batch(res, members, seed):
    probs = mei2010.dispersion(jax.random.PRNGKey(seed), members, "two-body")
    t0 = time.perf_counter()
    refine_batch(probs)
    first = time.perf_counter() - t0
    t0 = time.perf_counter()
    out = refine_batch(probs)
    steady = time.perf_counter() - t0
    rows = []
    for i in range(members):
        member = jax.tree_util.tree_map(lambda x: x[i], probs)
        sol = lpm.solve(member, throw=False)
        peer, ip, d = ipopt_on(member, sol.grid, repeats=1)
        rows.append(dict(peer, rung=int(sol.stats["rung"]), ours_status=int(sol.status),
                         cost_rel_diff=compare(sol.cost, np.asarray(sol.node_controls), ip,
                                               d)["cost_rel_diff"]))
        print(f"  member {i}: rung {rows[-1]['rung']}, IPOPT {peer['solve_median_s']:.3f} s "
              f"({peer['status']})", flush=True)
    ipopt_total = sum(r["solve_median_s"] for r in rows)
    sweep_res = refined_sweep(probs, out)
    res["batch"] = dict(
        members=members, seed=seed, dispersion="jaxlpm.cases.mei2010.dispersion, two-body",
        ours=dict(first_call_s=first, steady_s=steady,
                  status_counts={str(k): int(v) for k, v in
                                 zip(*np.unique(out["status"], return_counts=True))},
                  rung_counts={str(k): int(v) for k, v in
                               zip(*np.unique(out["rung"], return_counts=True))}),
        ipopt=dict(total_solve_s=ipopt_total,
                   build_total_s=sum(r["build_s"] for r in rows),
                   solved=sum(r["status"] == "Solve_Succeeded" for r in rows),
                   cost_rel_diff_max=max(r["cost_rel_diff"] for r in rows), rows=rows),
        throughput_ratio_ours_over_ipopt=ipopt_total / steady,
        sweep=dict(sweep_res, throughput_ratio_over_ipopt=ipopt_total / sweep_res["compute_s"]))
    b = res["batch"]
    print(f"[batch] {members} members: ours {steady:.2f} s steady (first {first:.1f} s), "
          f"IPOPT {ipopt_total:.2f} s of solves on the same final meshes: throughput ratio "
          f"{b['throughput_ratio_ours_over_ipopt']:.2f}", flush=True)
    sw = b["sweep"]
    print(f"[sweep] the same members through the sweep engine's 'refine' group (one chunk): "
          f"{sw['compute_s']:.2f} s of chunk compute (compiles {sw['compile_s']:.1f} s), "
          f"throughput ratio {sw['throughput_ratio_over_ipopt']:.2f}; costs against "
          f"refine_batch {sw['cost_rel_diff_max']:.1e}", flush=True)


def refined_sweep(probs, batch_out):
    """The batch through `jaxlpm.batch.sweep` with points ["refine"] (one chunk of all the
    members, on disk): its chunk compute seconds (the manifest's log, compiles apart) and the
    largest relative cost difference from `refine_batch`'s records `batch_out`."""
    params, build = problem_table(probs)
    family = SweepFamily(name="bench-refine", build=build)
    members = next(iter(params.values())).shape[0]
    with tempfile.TemporaryDirectory() as tmp:
        result = sweep(family, params, ["refine"], Path(tmp) / "sweep", chunk_size=members,
                       progress=False)
        manifest = json.loads((Path(tmp) / "sweep" / "manifest.json").read_text())
    table = result.tables["refine"]
    return dict(compute_s=sum(c["seconds"] for c in manifest["chunks"].values()),
                compile_s=sum(c["seconds"] for c in manifest["compiles"]),
                rung_counts={str(k): int(v) for k, v in
                             zip(*np.unique(table["rung"], return_counts=True))},
                cost_rel_diff_max=float(np.max(np.abs(table["cost"] / batch_out["cost"] - 1))))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="results/bench_refine.json")
    ap.add_argument("--members", type=int, default=32)
    ap.add_argument("--seed", type=int, default=3)
    args = ap.parse_args(argv)
    jax.config.update("jax_enable_x64", True)
    res = dict(date_utc=time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
               machine=machine_info(casadi=ca.__version__), ipopt_options=IPOPT_OPTIONS,
               ladder=[list(r) for r in lpm.DEFAULT_LADDER.rungs])
    single(res)
    if args.members:
        batch(res, args.members, args.seed)
    os.makedirs(os.path.dirname(args.out) or ".", exist_ok=True)
    with open(args.out, "w") as fh:
        json.dump(res, fh, indent=1)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
