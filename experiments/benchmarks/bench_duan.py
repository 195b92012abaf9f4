"""Benchmark of the minimum-time augmented-Lagrangian solver against CasADi + IPOPT (issue 4).

The NLP: `solve(duan.problem(), lg(100))`, the paper's Gauss pseudospectral
transcription (jaxlpm.problems.min_time / transcription) in the solver's units: s = n t, state
[r / L, v / (L n)] (L = |r_f|), control u (unit direction), acceleration a~ = (T / m) / (L n^2),
  unknowns     X (K + 2 rows: -1, the K LG points, +1) x 6, U (K x 3), s_f       (915)
  defects      D X_{0..K} - h (A X_k + a~ [0; U_k])              (K x 6)
  quadrature   X_f - X_0 - h sum_k w_k F_k                          (6)
  boundary     X_0 - x0, X_f - xf                                  (12)
  direction    |U_k|^2 - 1 = 0                                      (K)
  cost         s_f - s0,   h = (s_f - s0) / 2

Ours: the augmented-Lagrangian solver (the direction constraints in PHR terms, the rest hard in
the inner Newton-KKT), from its own initial guess (energy-optimal QP at the duration where its
RMS control equals the thrust). Peer: the SAME NLP written symbolically in CasADi (SX), all
constraints hard, solved by IPOPT (MUMPS, exact Hessian, tol 1e-10), from the same initial
point (ours, computed outside IPOPT's timing). D, the LG weights and the scaled boundary
states come from jaxlpm as parameters; the dynamics, defects and constraints are written out
again in CasADi. The two NLPs' identity is checked by evaluating both constraint vectors at the
initial point, and the optima agree in t_f.

Measured: our cold compile (lower + compile, caches cleared, persistent cache off), our
steady-state time (median of repeats), IPOPT's build time and solve time (median of repeats);
the ratio ours / IPOPT of steady-state times. Wall and process CPU time are both recorded.

Run:  python experiments/benchmarks/bench_duan.py [--K 100]     (K: LG points, the paper's K)
      [--out results/bench_duan.json]          (needs the `peer` extra: casadi)
"""

import argparse
import json
import os
import time

from jaxlpm import lg, solve  # first: it sets the CPU runtime before numpy/casadi load

import casadi as ca  # noqa: E402
import jax  # noqa: E402
import numpy as np  # noqa: E402

from common import block, cold_compile, machine_info, timed  # noqa: E402  (this directory)
from jaxlpm.cases import duan  # noqa: E402
from jaxlpm.dynamics import hcw_matrix  # noqa: E402
from jaxlpm.problems.min_time import duration_lower_bound, min_time_ocp  # noqa: E402
from jaxlpm.nlp.transcription import equality, path_values  # noqa: E402
from jaxlpm.solvers.min_time import initial_guess  # noqa: E402

IPOPT_OPTIONS = {"ipopt.tol": 1e-10, "ipopt.print_level": 0, "ipopt.sb": "yes",
                 "ipopt.hessian_approximation": "exact", "ipopt.linear_solver": "mumps",
                 "print_time": False}


def build_ipopt(K, D, w, options=IPOPT_OPTIONS):
    """The LG minimum-time NLP in CasADi; parameters [x0 (6), xf (6), accel, s0]."""
    A = ca.DM(np.asarray(hcw_matrix(1.0)))
    X = ca.SX.sym("X", K + 2, 6)
    U = ca.SX.sym("U", K, 3)
    sf = ca.SX.sym("sf")
    p = ca.SX.sym("p", 14)
    x0, xf, acc, s0 = p[0:6], p[6:12], p[12], p[13]
    h = 0.5 * (sf - s0)
    F = ca.vertcat(*[(A @ X[k + 1, :].T + ca.vertcat(ca.DM.zeros(3), acc * U[k, :].T)).T
                     for k in range(K)])                         # K x 6
    Dm = ca.DM(np.asarray(D))
    defects = Dm @ X[:K + 1, :] - h * F
    quad = X[K + 1, :] - X[0, :] - h * (ca.DM(np.asarray(w)).T @ F)
    g = ca.vertcat(ca.reshape(defects.T, -1, 1), quad.T, X[0, :].T - x0, X[K + 1, :].T - xf,
                   ca.sum2(U * U) - 1.0)
    z = ca.vertcat(ca.reshape(X.T, -1, 1), ca.reshape(U.T, -1, 1), sf)
    nlp = {"x": z, "p": p, "f": sf - s0, "g": g}
    t = time.perf_counter()
    solver = ca.nlpsol("duan_peer", "ipopt", nlp, dict(options))
    constraints = ca.Function("g", [z, p], [g])
    return solver, constraints, time.perf_counter() - t, int(z.shape[0]), int(g.shape[0])


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--K", type=int, default=100, help="LG points (the paper's K = 100)")
    ap.add_argument("--out", default="results/bench_duan.json")
    args = ap.parse_args(argv)
    jax.config.update("jax_enable_x64", True)
    prob, grid = duan.problem(), lg(args.K)
    res = {"machine": machine_info(casadi=ca.__version__), "K": args.K}

    def ours_fn(p):
        return solve(p, grid, throw=False)          # the augmented-Lagrangian solver

    compiled, comp = cold_compile(ours_fn, prob)
    sol = block(compiled(prob))
    run = timed(lambda: block(compiled(prob)), min_repeats=3, budget_s=20.0)
    ours = dict(compile=comp, solve=run, tf=float(sol.duration), status=int(sol.status),
                outer_iterations=int(sol.stats["outer_iterations"]),
                inner_iterations=int(sol.stats["inner_iterations"]))
    print(f"[ours] compile {comp['total_s']:.1f} s (lower {comp['lower_s']:.1f}), solve "
          f"{run['median_s']:.3f} s (median of {run['repeats']}), t_f = {ours['tf']:.9f} s, "
          f"{ours['outer_iterations']} outer / {ours['inner_iterations']} Newton iterations")

    ocp = min_time_ocp(prob, 0.0)
    z0 = initial_guess(ocp, grid, float(prob.orbit.mean_motion * duration_lower_bound(prob)))[0]
    ocp = ocp.replace(sf=z0[-1])
    P = ocp.params
    pvec = np.concatenate([np.asarray(P["x0"]), np.asarray(P["xf"]), [float(P["accel"])],
                           [float(ocp.s0)]])
    solver, g_fun, build_s, nv, nc = build_ipopt(args.K, grid.D, grid.weights)
    # the same NLP: our equality constraints and path values at z0 vs CasADi's
    _, H, _ = path_values(z0, ocp, grid)
    ours_g = np.concatenate([np.asarray(equality(z0, ocp, grid)), np.asarray(H).ravel()])
    peer_g = np.asarray(g_fun(np.asarray(z0), pvec)).ravel()
    same = float(np.max(np.abs(ours_g - peer_g)))
    print(f"[check] |g_ours - g_casadi| at the initial point: {same:.2e} ({nv} unknowns, "
          f"{nc} constraints)")
    n = float(prob.orbit.mean_motion)

    def ipopt_solve():
        t, c = time.perf_counter(), time.process_time()
        out = solver(x0=np.asarray(z0), p=pvec, lbg=0.0, ubg=0.0)
        stats = solver.stats()
        return dict(wall_s=time.perf_counter() - t, cpu_s=time.process_time() - c,
                    tf=(float(out["x"][-1]) - float(ocp.s0)) / n,
                    status=stats["return_status"], iterations=stats["iter_count"])

    first = ipopt_solve()
    runs = [ipopt_solve() for _ in range(5)]
    times = sorted(r["wall_s"] for r in runs)
    ipopt = dict(build_s=build_s, first=first, median_s=times[len(times) // 2],
                 cpu_median_s=sorted(r["cpu_s"] for r in runs)[len(runs) // 2],
                 tf=runs[-1]["tf"], status=runs[-1]["status"],
                 iterations=runs[-1]["iterations"], variables=nv, constraints=nc)
    print(f"[ipopt] build {build_s:.2f} s, solve {ipopt['median_s']:.3f} s (median of 5), "
          f"{ipopt['iterations']} iterations, {ipopt['status']}, t_f = {ipopt['tf']:.9f} s")
    res.update(ours=ours, ipopt=ipopt, constraint_identity=same,
               tf_difference=ours["tf"] - ipopt["tf"],
               ratio_ours_over_ipopt=run["median_s"] / ipopt["median_s"],
               cpu_ratio_ours_over_ipopt=run["cpu_median_s"] / ipopt["cpu_median_s"],
               loadavg_end=os.getloadavg())
    print(f"steady-state ratio ours / IPOPT: {res['ratio_ours_over_ipopt']:.2f} (wall), "
          f"{res['cpu_ratio_ours_over_ipopt']:.2f} (CPU); t_f difference "
          f"{res['tf_difference']:.2e} s")
    os.makedirs(os.path.dirname(args.out) or ".", exist_ok=True)
    with open(args.out, "w") as fh:
        json.dump(res, fh, indent=2, default=str)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
