"""Benchmark of the batched CARE / infinite-horizon HCW LQR design against a loop over
scipy.linalg.solve_continuous_are (the field's standard: ordered QZ of the extended pencil).

Case (jiang2011, docs/jiang2011.md): HCW about a circular chief at 343 km altitude; 10^4 (Q, R)
weightings around Bryson's rule, Q = diag(q_i / s_i^2) with s = (1 km x 3, 1 m/s x 3) and
R = diag(r_j) / (1 mm/s^2)^2, the factors q_i, r_j log-uniform in [1e-2, 1e2] (seed 0). SI
units in both solvers (`hcw_lqr` nondimensionalises inside; scipy balances). `jaxlpm.hcw_lqr`
is the design alone (a `CareSolution`); `jaxlpm.solve(LQRTransfer(..., terminal="infinite"))`
runs the same CARE and then flies the law (not timed here).

Measured in one run:
  1. jax.jit(jax.vmap(hcw_lqr, in_axes=(None, 0, 0))) on the 10^4 weightings in one call: cold
     compile time (lower + compile, in-memory caches cleared, persistent cache off) and the
     steady-state time per call (median of repeats, block_until_ready), statuses;
  2. the same function on 10^3 weightings (batch-size scaling), and the 10^4 in one call as
     lax.map over 10 vmapped chunks of 10^3;
  3. one problem at a time through `hcw_lqr` (host validation by the compiled weight checks
     of `jaxlpm.problems.lqr.weight_rules`, scaling around the compiled `care`: the latency a
     script sees);
  4. scipy.linalg.solve_continuous_are in a Python loop over the first --n-peer weightings
     (time per problem, median of 3 passes), plus K = R^-1 B^T P (scipy.linalg.solve) as
     both solvers return the gain;
  5. agreement: max ||P_jax - P_scipy||_F / ||P_scipy||_F over the peer's problems, and both
     methods' relative residuals ||A^T P + P A - P B R^-1 B^T P + Q||_F / ||Q||_F evaluated in
     numpy in the solver's nondimensional scaling (time 1/n), so the two are comparable.

Run:  python experiments/benchmarks/bench_care.py [--out results/bench_care.json]
"""

import argparse
import json
import os
import statistics
import sys
import time

# jaxlpm sets its CPU runtime at import (one OpenBLAS thread, XLA's sequential CPU scheduler):
# import it before numpy/scipy so the peer runs under the same settings.
from jaxlpm import hcw_lqr  # noqa: E402

import jax  # noqa: E402

jax.config.update("jax_enable_x64", True)
jax.config.update("jax_enable_compilation_cache", False)   # cold compiles, measured

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
import scipy  # noqa: E402
import scipy.linalg as sl  # noqa: E402

from jaxlpm.cases import jiang2011  # noqa: E402
from jaxlpm.dynamics import hcw_matrix  # noqa: E402
from common import cold_compile, machine_info, timed  # noqa: E402  (this directory)

BATCH = 10_000
SMALL_BATCH = 1_000


def weightings(count, seed=0):
    """(Qs (count, 6, 6), Rs (count, 3, 3)) in SI around the case's Bryson weights."""
    rng = np.random.default_rng(seed)
    Q0, R0 = jiang2011.weights()
    q = 10 ** rng.uniform(-2, 2, (count, 6))
    r = 10 ** rng.uniform(-2, 2, (count, 3))
    Qs = q[:, :, None] * np.eye(6)[None] * np.diag(Q0)[None, :, None]
    Rs = r[:, :, None] * np.eye(3)[None] * np.diag(R0)[None, :, None]
    return Qs, Rs


def nondimensional_residual(P, n, Q, R):
    """||F(P^)||_F / ||Q^||_F of the CARE in time 1/n (P^ = n S P S, Q^ = S Q S, R^ = n^4 R,
    S = diag(1, 1, 1, n, n, n)): the scaling `hcw_lqr` solves in."""
    s = np.array([1, 1, 1, n, n, n])
    Ph, Qh, Rh = n * s[:, None] * P * s[None, :], s[:, None] * Q * s[None, :], n**4 * R
    A, B = np.asarray(hcw_matrix(1.0)), np.vstack([np.zeros((3, 3)), np.eye(3)])
    F = A.T @ Ph + Ph @ A - Ph @ B @ np.linalg.solve(Rh, B.T) @ Ph + Qh
    return np.linalg.norm(F) / np.linalg.norm(Qh)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="results/bench_care.json")
    ap.add_argument("--batch", type=int, default=BATCH)
    ap.add_argument("--n-peer", type=int, default=1000,
                    help="weightings solved one at a time by scipy (and compared)")
    args = ap.parse_args(argv)
    t_start = time.perf_counter()
    n = jiang2011.mean_motion()
    A = np.asarray(hcw_matrix(n))
    B = np.vstack([np.zeros((3, 3)), np.eye(3)])
    Qs, Rs = weightings(args.batch)
    res = dict(case=dict(chief_altitude_m=jiang2011.ALTITUDE, n_rad_s=n, batch=args.batch,
                         weights="Q = diag(q_i / s_i^2), R = diag(r_j) / (1e-3 m/s^2)^2, "
                                 "q, r log-uniform in [1e-2, 1e2], seed 0; SI"),
               machine=machine_info(scipy=scipy.__version__))

    # 1-2. batched ---------------------------------------------------------------------------
    batched_fn = jax.vmap(hcw_lqr, in_axes=(None, 0, 0))
    nj = jnp.float64(n)
    batched = {}
    for size in (args.batch, SMALL_BATCH):
        Qb, Rb = jnp.asarray(Qs[:size]), jnp.asarray(Rs[:size])
        compiled, comp = cold_compile(batched_fn, nj, Qb, Rb)
        sols = jax.block_until_ready(compiled(nj, Qb, Rb))
        run = timed(lambda: jax.block_until_ready(compiled(nj, Qb, Rb)))
        status = np.asarray(sols.status)
        batched[size] = dict(compile=comp, call=run, problems_per_s=size / run["median_s"],
                             per_problem_us=run["median_s"] / size * 1e6,
                             status_counts={int(k): int(v) for k, v in
                                            zip(*np.unique(status, return_counts=True))},
                             max_residual=float(np.max(np.asarray(sols.residual))),
                             sign_iterations_max=int(np.max(np.asarray(sols.iterations))),
                             sign_iterations_mean=float(np.mean(np.asarray(sols.iterations))))
        print(f"[jax vmap x{size}] compile {comp['total_s']:.2f} s, call "
              f"{run['median_s'] * 1e3:.1f} ms ({batched[size]['per_problem_us']:.1f} us/problem,"
              f" {batched[size]['problems_per_s']:.0f}/s), status {batched[size]['status_counts']}"
              f", max residual {batched[size]['max_residual']:.1e}", flush=True)
        if size == args.batch:
            big = sols
    res["batched"] = {str(k): v for k, v in batched.items()}

    # 2b. the 10^4 weightings in one call as lax.map over chunks of 10^3 (each chunk's sign
    # iteration stops at its own slowest member instead of the whole batch's)
    chunks = args.batch // SMALL_BATCH
    if chunks > 1 and args.batch % SMALL_BATCH == 0:
        def chunked(nv, Qb, Rb):
            split = lambda M: M.reshape((chunks, SMALL_BATCH) + M.shape[1:])
            out = jax.lax.map(lambda qr: batched_fn(nv, *qr), (split(Qb), split(Rb)))
            return jax.tree_util.tree_map(lambda x: x.reshape((args.batch,) + x.shape[2:]), out)

        Qb, Rb = jnp.asarray(Qs), jnp.asarray(Rs)
        compiled, comp = cold_compile(chunked, nj, Qb, Rb)
        sols = jax.block_until_ready(compiled(nj, Qb, Rb))
        run = timed(lambda: jax.block_until_ready(compiled(nj, Qb, Rb)))
        res["chunked"] = dict(chunk=SMALL_BATCH, compile=comp, call=run,
                              problems_per_s=args.batch / run["median_s"],
                              per_problem_us=run["median_s"] / args.batch * 1e6,
                              P_rel_diff_vs_vmap=float(np.max(
                                  np.linalg.norm(np.asarray(sols.P - big.P), axis=(1, 2))
                                  / np.linalg.norm(np.asarray(big.P), axis=(1, 2)))))
        c = res["chunked"]
        print(f"[jax lax.map over {chunks} vmap chunks of {SMALL_BATCH}] compile "
              f"{comp['total_s']:.2f} s, call {run['median_s'] * 1e3:.1f} ms "
              f"({c['per_problem_us']:.1f} us/problem), P vs vmap {c['P_rel_diff_vs_vmap']:.0e}",
              flush=True)

    # 3. one at a time through the jitted function ---------------------------------------------
    hcw_lqr(n, Qs[0], Rs[0])                                  # compile (validated path)
    m = min(200, args.batch)
    t0 = time.perf_counter()
    for i in range(m):
        jax.block_until_ready(hcw_lqr(n, Qs[i], Rs[i]))
    single = (time.perf_counter() - t0) / m
    res["single"] = dict(per_problem_s=single, problems=m)
    print(f"[jax one at a time] {single * 1e3:.3f} ms/problem", flush=True)

    # 4. scipy loop ------------------------------------------------------------------------------
    npeer = min(args.n_peer, args.batch)
    passes = []
    for _ in range(3):
        t0 = time.perf_counter()
        Ps = []
        for i in range(npeer):
            P = sl.solve_continuous_are(A, B, Qs[i], Rs[i])
            sl.solve(Rs[i], B.T @ P, assume_a="pos")
            Ps.append(P)
        passes.append((time.perf_counter() - t0) / npeer)
    per = statistics.median(passes)
    res["scipy"] = dict(per_problem_s=per, problems_per_s=1.0 / per, problems=npeer,
                        passes=passes, version=scipy.__version__)
    print(f"[scipy solve_continuous_are loop] {per * 1e3:.3f} ms/problem "
          f"({1.0 / per:.0f}/s, {npeer} problems)", flush=True)

    # 5. agreement -------------------------------------------------------------------------------
    Pj = np.asarray(big.P[:npeer])
    rel = [np.linalg.norm(Pj[i] - Ps[i]) / np.linalg.norm(Ps[i]) for i in range(npeer)]
    rj = [nondimensional_residual(Pj[i], n, Qs[i], Rs[i]) for i in range(npeer)]
    rs = [nondimensional_residual(Ps[i], n, Qs[i], Rs[i]) for i in range(npeer)]
    res["agreement"] = dict(P_rel_diff_max=float(max(rel)),
                            P_rel_diff_median=float(statistics.median(rel)),
                            residual_jax_max=float(max(rj)), residual_scipy_max=float(max(rs)),
                            residual_jax_median=float(statistics.median(rj)),
                            residual_scipy_median=float(statistics.median(rs)))
    a = res["agreement"]
    print(f"[agreement] ||P - P_scipy|| / ||P_scipy|| max {a['P_rel_diff_max']:.1e}; residual max "
          f"jax {a['residual_jax_max']:.1e}, scipy {a['residual_scipy_max']:.1e}", flush=True)

    ratios = {str(k): v["problems_per_s"] / res["scipy"]["problems_per_s"]
              for k, v in batched.items()}
    ratios["single"] = per / single
    if "chunked" in res:
        ratios["chunked"] = res["chunked"]["problems_per_s"] / res["scipy"]["problems_per_s"]
    res["ratios_vs_scipy"] = ratios
    res["machine"]["loadavg_end"] = os.getloadavg()
    res["total_runtime_s"] = time.perf_counter() - t_start
    res["command"] = " ".join([os.path.basename(sys.executable)] + sys.argv)
    print(f"\nthroughput ratio vs the scipy loop: vmap x{args.batch} "
          f"{ratios[str(args.batch)]:.1f}x, vmap x{SMALL_BATCH} "
          f"{ratios[str(SMALL_BATCH)]:.1f}x, chunked {ratios.get('chunked', float('nan')):.1f}x,"
          f" one at a time {ratios['single']:.2f}x")
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    with open(args.out, "w") as fh:
        json.dump(res, fh, indent=2, default=float)
    print(f"wrote {args.out} (total {res['total_runtime_s']:.0f} s)")
    return res


if __name__ == "__main__":
    main()
