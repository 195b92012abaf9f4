"""Benchmark of the two LQ laws (stm_law, kkt_law) against CasADi+IPOPT and a scipy sparse solve.

Case: Mei, Ma & Yang (2010): chief a = 9500 km, f0 = 0, x0 = [10 km, 10 km, 0, 4, -23.485, 0]
(LVLH m, m/s), xf = 0, 3 revolutions, LGL N = 64 (65 nodes), float64, 3D (in-plane and
out-of-plane) everywhere.

Measured in one run:
  1. per law, one problem (e = 0.3): cold compile time (jax.jit(law).lower(...).compile(), the
     in-memory caches cleared first, the persistent compilation cache off) and steady-state time
     per solve (jitted, block_until_ready, median of repeats);
  2. per law, 1024 problems (e = linspace(0, 0.5, 1024)) through jax.jit(jax.vmap(law)):
     compile time, time per batch, problems/s, how many members return status 0;
  3. peer A: the same collocated QP (Mei 2010 eq. 12-16) in CasADi, solved by IPOPT one problem
     at a time; the solver is built once with the e-dependent data as parameters;
  4. peer B: the KKT system of the same QP assembled as a scipy.sparse matrix and solved by
     scipy.sparse.linalg.spsolve (SuperLU), per problem;
  5. throughput ratios, and a breakdown of the STM law's time.

The peers get the node true anomalies, rho_i, (fT - f0)/2 and the Tschauner-Hempel boundary
states from jaxlpm.solvers.lq._setup (computed once, outside their timings), so all three solve
exactly the same discrete problem; their costs are compared with kkt_law's cost_true_anomaly.

Run:  PYTHONPATH=. python experiments/benchmarks/bench_lq_laws.py [--out results/bench_lq_laws.json]
"""

import argparse
import json
import os
import statistics
import sys
import time

# jaxlpm sets its CPU runtime at import (jaxlpm/_cpu_runtime.py: one OpenBLAS thread, XLA's
# sequential CPU scheduler, which avoids a jaxlib 0.10 deadlock in batched QR): import it before
# numpy/scipy so the peers run under the same settings.
from jaxlpm import EnergyOptimalTransfer, KeplerOrbit, lgl, solve  # noqa: E402

import faulthandler  # noqa: E402

import jax  # noqa: E402

jax.config.update("jax_enable_x64", True)
jax.config.update("jax_enable_compilation_cache", False)   # cold compiles, measured

import casadi as ca  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
import scipy  # noqa: E402
import scipy.sparse as sp  # noqa: E402
import scipy.sparse.linalg as spla  # noqa: E402

from jaxlpm.solvers.lq import _setup, kkt_law, stm_law  # noqa: E402
from common import block, cold_compile, machine_info, timed  # noqa: E402  (this directory)

A_CHIEF = 9500e3
E_CASE = 0.3
X0_LVLH = np.array([10000.0, 10000.0, 0.0, 4.0, -23.485, 0.0])
XF_LVLH = np.zeros(6)
REVOLUTIONS = 3.0
N_POINTS = 65                         # LGL N = 64
BATCH = 1024
E_MAX = 0.5
GOALS = {"stm": 2000.0, "kkt": 10.0}  # batched problems/s over IPOPT problems/s
LAWS = {"stm": stm_law, "kkt": kkt_law}


# ----------------------------------------------------------------------------------- helpers
def make_problem(e):
    orbit = KeplerOrbit(a=jnp.float64(A_CHIEF), e=jnp.float64(e))
    return EnergyOptimalTransfer.from_revolutions(
        orbit, jnp.asarray(X0_LVLH), jnp.asarray(XF_LVLH), REVOLUTIONS)


def make_batch(es):
    """One problem pytree whose every leaf has a leading batch axis; orbit.e = es."""
    base = make_problem(E_CASE)
    b = len(es)
    batched = jax.tree.map(
        lambda leaf: jnp.broadcast_to(jnp.asarray(leaf, jnp.float64),
                                      (b,) + jnp.shape(leaf)), base)
    return batched.replace(orbit=batched.orbit.replace(e=jnp.asarray(es, jnp.float64)))


def th_data(problems, grid):
    """Per-member data of the TH-frame QP from jaxlpm's own prelude (batched, host arrays)."""
    def one(p):
        s = _setup(p, grid)
        return dict(f=s["f"], rho=s["rho"], half=s["half"], X0=s["X0"], XT=s["XT"], k2=s["k2"],
                    e=s["e"])
    out = jax.jit(jax.vmap(one))(problems)
    return {k: np.asarray(v) for k, v in out.items()}


# ------------------------------------------------------------------------- the QP (eq. 12-16)
# Unknowns per axis a (x, y, z): nodal positions Q_a, velocities V_a (TH, m and m/rad) and
# controls U_a (m). Tschauner-Hempel equations collocated at all LGL nodes (Mei 2010 eq. 12),
# written in the pseudospectral form D X = h F(X, U), h = (fT - f0)/2:
#   D Q_a - h V_a = 0                                   (a = x, y, z)
#   D V_x - h (3/rho Q_x + 2 V_y + U_x / rho^3) = 0
#   D V_y - h (-2 V_x + U_y / rho^3) = 0
#   D V_z - h (-Q_z + U_z / rho^3) = 0
#   X(f_0) = X0, X(f_N) = XT (TH states)
# Cost (Mei 2010 eq. 5 by LGL quadrature): 1/2 sum_i h w_i / rho_i^2 |U_i|^2 (TH units, m^2);
# jaxlpm's cost_true_anomaly is k2^4 times this cost (u = k2^2 U). Same equations, unknowns and
# constraints as jaxlpm's kkt_law (which eliminates V and U before solving), 3D.

def build_ipopt(D, w, extra_options=None):
    """CasADi NLP of the QP with parameters p = [rho (n), h, X0 (6), XT (6)]; built once."""
    n = D.shape[0]
    Q = ca.SX.sym("Q", n, 3)
    V = ca.SX.sym("V", n, 3)
    U = ca.SX.sym("U", n, 3)
    rho = ca.SX.sym("rho", n)
    h = ca.SX.sym("h")
    X0 = ca.SX.sym("X0", 6)
    XT = ca.SX.sym("XT", 6)
    Dm = ca.DM(D)
    b = 1.0 / rho**3
    acc = ca.horzcat(3.0 / rho * Q[:, 0] + 2.0 * V[:, 1] + b * U[:, 0],
                     -2.0 * V[:, 0] + b * U[:, 1],
                     -Q[:, 2] + b * U[:, 2])
    defects = [ca.vec(ca.mtimes(Dm, Q) - h * V), ca.vec(ca.mtimes(Dm, V) - h * acc)]
    X = ca.horzcat(Q, V)
    bc = [X[0, :].T - X0, X[n - 1, :].T - XT]
    c = h * ca.DM(w) / rho**2
    cost = 0.5 * ca.sum1(c * ca.sum2(U**2))
    x = ca.vertcat(ca.vec(Q), ca.vec(V), ca.vec(U))
    p = ca.vertcat(rho, h, X0, XT)
    nlp = dict(x=x, p=p, f=cost, g=ca.vertcat(*defects, *bc))
    opts = {"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes",
            **(extra_options or {})}
    solver = ca.nlpsol("lq_qp", "ipopt", nlp, opts)
    return solver, x.numel(), nlp["g"].numel()


class SparseKKT:
    """The KKT matrix [[H, A^T], [A, 0]] of the QP as a scipy CSC matrix with a fixed pattern.

    Variables [Q_x, Q_y, Q_z, V_x, V_y, V_z, U_x, U_y, U_z] (n each), constraint rows as in
    build_ipopt (position-rate defects, velocity-rate defects, boundary states). The pattern and
    the e-independent entries (the D blocks, the boundary rows) are built once; per problem only
    the diagonal blocks that depend on h = (fT - f0)/2 and rho_i are filled, then permuted into
    CSC order (so assembly is a gather, not a sparse-matrix construction).
    """

    def __init__(self, D):
        n = self.n = D.shape[0]
        nv, nc = 9 * n, 6 * n + 12
        self.size = nv + nc
        col = {name: k * n for k, name in enumerate(
            ["Qx", "Qy", "Qz", "Vx", "Vy", "Vz", "Ux", "Uy", "Uz"])}
        rows, cols, const = [], [], []
        dr, dc = np.nonzero(np.ones((n, n)))
        for a, ax in enumerate("xyz"):                     # D blocks: D Q_a and D V_a
            for r0, c0 in ((a * n, col["Q" + ax]), ((3 + a) * n, col["V" + ax])):
                rows.append(r0 + dr), cols.append(c0 + dc), const.append(D[dr, dc])
        for k, name in enumerate(["Qx", "Qy", "Qz", "Vx", "Vy", "Vz"]):   # boundary rows
            rows.append(6 * n + 2 * k + np.array([0, 1]))
            cols.append(col[name] + np.array([0, n - 1]))
            const.append(np.ones(2))
        self.n_const = sum(len(c) for c in const)
        # diagonal blocks depending on (h, rho): (row block, column name, value key)
        self.diag = [(0, "Vx", "-h"), (1, "Vy", "-h"), (2, "Vz", "-h"),
                     (3, "Qx", "-3h/rho"), (3, "Vy", "-2h"), (3, "Ux", "-h/rho3"),
                     (4, "Vx", "2h"), (4, "Uy", "-h/rho3"),
                     (5, "Qz", "h"), (5, "Uz", "-h/rho3")]
        idx = np.arange(n)
        for rb, name, _ in self.diag:
            rows.append(rb * n + idx), cols.append(col[name] + idx)
        ar, ac = np.concatenate(rows), np.concatenate(cols)
        self.n_A = len(ar)
        # K: H on the U diagonal, A below, A^T to the right
        kr = np.concatenate([col["Ux"] + np.arange(3 * n), nv + ar, ac])
        kc = np.concatenate([col["Ux"] + np.arange(3 * n), ac, nv + ar])
        marker = sp.csc_matrix((np.arange(1, len(kr) + 1, dtype=np.float64), (kr, kc)),
                               shape=(self.size, self.size))
        marker.sort_indices()
        self.perm = marker.data.astype(np.int64) - 1      # CSC slot -> COO entry
        self.indices, self.indptr = marker.indices.copy(), marker.indptr.copy()
        self.const = np.concatenate(const)

    def assemble(self, w, rho, h, X0, XT):
        n = self.n
        vals = {"-h": np.full(n, -h), "2h": np.full(n, 2.0 * h), "-2h": np.full(n, -2.0 * h),
                "h": np.full(n, h), "-3h/rho": -3.0 * h / rho, "-h/rho3": -h / rho**3}
        a_vals = np.concatenate([self.const] + [vals[key] for _, _, key in self.diag])
        c = h * w / rho**2
        coo = np.concatenate([c, c, c, a_vals, a_vals])
        K = sp.csc_matrix((coo[self.perm], self.indices, self.indptr),
                          shape=(self.size, self.size))
        rhs = np.zeros(self.size)
        rhs[15 * n:] = np.stack([X0, XT], axis=1).ravel()
        return K, rhs


def th_cost(U, w, rho, h):
    """1/2 sum_i h w_i |U_i|^2 / rho_i^2 for U (n, 3)."""
    return 0.5 * h * float(np.sum(w * np.sum(U**2, axis=1) / rho**2))


# ----------------------------------------------------------------------------------- machine
# -------------------------------------------------------------------------------------- main
def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="results/bench_lq_laws.json")
    ap.add_argument("--n-peer", type=int, default=32,
                    help="problems (eccentricities) solved one at a time by each peer")
    ap.add_argument("--batch", type=int, default=BATCH)
    ap.add_argument("--watchdog", type=float, default=900.0,
                    help="abort with a traceback after this many seconds (a hung XLA pool)")
    args = ap.parse_args(argv)
    faulthandler.dump_traceback_later(args.watchdog, exit=True)
    t_start = time.perf_counter()
    res = dict(case=dict(a_m=A_CHIEF, e_single=E_CASE, x0_lvlh=X0_LVLH.tolist(),
                         xf_lvlh=XF_LVLH.tolist(), revolutions=REVOLUTIONS,
                         lgl_points=N_POINTS, N=N_POINTS - 1, batch=args.batch,
                         e_batch=[0.0, E_MAX], dimension="3D (in-plane + out-of-plane)"),
               machine=machine_info(casadi=ca.__version__, scipy=scipy.__version__))
    grid = lgl(N_POINTS)
    prob = make_problem(E_CASE)

    # 1. single problem --------------------------------------------------------------------
    single = {}
    for name, law in LAWS.items():
        compiled, comp = cold_compile(law, prob, grid)
        sol = block(compiled(prob, grid))
        jitted = jax.jit(law)
        block(jitted(prob, grid))
        run = timed(lambda: block(jitted(prob, grid)), min_repeats=20, budget_s=2.0)
        run_aot = timed(lambda: block(compiled(prob, grid)), min_repeats=20, budget_s=1.0)
        single[name] = dict(compile=comp, solve=run, solve_aot_executable=run_aot,
                            status=int(sol.status), cost=float(sol.cost),
                            cost_true_anomaly=float(sol.stats["cost_true_anomaly"]))
        print(f"[single {name}] compile {comp['total_s']:.3f} s, solve "
              f"{run['median_s'] * 1e3:.3f} ms (median of {run['repeats']})", flush=True)
    # solve() is the public entry point: the jitted law plus host-side validation
    for name in LAWS:
        block(solve(prob, grid, method=name, throw=False))
        single[name]["solve_public_api"] = timed(
            lambda: block(solve(prob, grid, method=name, throw=False)), min_repeats=10,
            budget_s=1.0)
    res["single"] = single

    # 2. batched ----------------------------------------------------------------------------
    es = np.linspace(0.0, E_MAX, args.batch)
    probs = make_batch(es)
    batched, batch_sols = {}, {}
    for name, law in LAWS.items():
        vlaw = jax.vmap(law, in_axes=(0, None))
        compiled, comp = cold_compile(vlaw, probs, grid, repeats=2)
        sols = block(compiled(probs, grid))
        jitted = jax.jit(vlaw)
        block(jitted(probs, grid))
        run = timed(lambda: block(jitted(probs, grid)), min_repeats=5, budget_s=6.0)
        status = np.asarray(sols.status)
        batched[name] = dict(compile=comp, batch=run,
                             per_problem_s=run["median_s"] / args.batch,
                             problems_per_s=args.batch / run["median_s"],
                             converged=int(np.sum(status == 0)), members=int(status.size),
                             status_counts={int(k): int(v) for k, v in
                                            zip(*np.unique(status, return_counts=True))})
        batch_sols[name] = sols
        print(f"[batch {name}] compile {comp['total_s']:.3f} s, batch "
              f"{run['median_s'] * 1e3:.1f} ms, {batched[name]['problems_per_s']:.0f} problems/s,"
              f" status 0: {batched[name]['converged']}/{status.size}", flush=True)
    cst = np.asarray(batch_sols["stm"].stats["cost_true_anomaly"])
    ckk = np.asarray(batch_sols["kkt"].stats["cost_true_anomaly"])
    batched["stm_vs_kkt_cost_max_rel_diff"] = float(np.max(np.abs(cst - ckk) / np.abs(ckk)))
    # batched members equal single solves (spot check at the member nearest e = 0.3)
    i03 = int(np.argmin(np.abs(es - E_CASE)))
    s03 = block(jax.jit(kkt_law)(make_problem(float(es[i03])), grid))
    batched["kkt_batch_vs_single_rel_diff"] = float(
        abs(ckk[i03] - float(s03.stats["cost_true_anomaly"]))
        / abs(float(s03.stats["cost_true_anomaly"])))
    res["batched"] = batched

    # shared TH data for the peers (from jaxlpm's prelude; not timed)
    data = th_data(probs, grid)
    D = np.asarray(grid.D)
    w = np.asarray(grid.weights)
    n = D.shape[0]
    idx = np.unique(np.linspace(0, args.batch - 1, args.n_peer).round().astype(int))
    kkt_X = np.asarray(batch_sols["kkt"].stats["node_states_th"])
    kkt_U_si = np.asarray(batch_sols["kkt"].node_controls)

    def rel_state_err(i, Q, V):
        X = np.concatenate([Q, V], axis=1)
        return float(np.max(np.abs(X - kkt_X[i])) / np.max(np.abs(kkt_X[i])))

    # 3. peer A: CasADi + IPOPT -----------------------------------------------------------------
    def run_ipopt(extra_options, members):
        t0 = time.perf_counter()
        solver, nvar, ncon = build_ipopt(D, w, extra_options)
        build_s = time.perf_counter() - t0
        x_init = np.zeros(nvar)
        times, evals, iters, rel, state, status = [], [], [], [], [], []
        for i in members:
            p = np.concatenate([data["rho"][i], [data["half"][i]], data["X0"][i], data["XT"][i]])
            t0 = time.perf_counter()
            out = solver(x0=x_init, p=p, lbg=0.0, ubg=0.0)
            times.append(time.perf_counter() - t0)
            st = solver.stats()
            z = np.asarray(out["x"]).ravel()
            Q, V, U = (z[k * 3 * n:(k + 1) * 3 * n].reshape(3, n).T for k in range(3))
            cost = th_cost(U, w, data["rho"][i], data["half"][i]) * data["k2"][i] ** 4
            evals.append(sum(v for k, v in st.items() if k.startswith("t_wall_nlp_")))
            iters.append(int(st["iter_count"]))
            status.append(st["return_status"])
            rel.append(abs(cost - ckk[i]) / abs(ckk[i]))
            state.append(rel_state_err(i, Q, V))
        r = dict(build_s=build_s, variables=nvar, constraints=ncon, problems=len(members),
                 per_problem=dict(median_s=statistics.median(times), min_s=min(times)),
                 casadi_function_evaluations_median_s=statistics.median(evals),
                 iterations=sorted(set(iters)), return_status=sorted(set(status)),
                 all_succeeded=all(x == "Solve_Succeeded" for x in status),
                 cost_rel_diff_vs_kkt_max=max(rel),
                 cost_rel_diff_vs_kkt_median=statistics.median(rel),
                 state_rel_diff_vs_kkt_max=max(state),
                 options={"ipopt.print_level": 0, "print_time": False, "ipopt.sb": "yes",
                          **(extra_options or {})})
        r["problems_per_s"] = 1.0 / r["per_problem"]["median_s"]
        return r

    ipopt = run_ipopt(None, idx)          # IPOPT defaults: MUMPS, tol 1e-8
    ipopt["e_values"] = es[idx].tolist()
    res["ipopt"] = ipopt
    # the same with IPOPT told that the derivatives are constant (a QP): fewer evaluations
    res["ipopt_constant_derivatives"] = run_ipopt(
        {"ipopt.hessian_constant": "yes", "ipopt.jac_c_constant": "yes",
         "ipopt.jac_d_constant": "yes"}, idx[::2])
    print(f"[ipopt] {ipopt['per_problem']['median_s'] * 1e3:.2f} ms/problem "
          f"({len(idx)} problems, iterations {ipopt['iterations']}, "
          f"{ipopt['return_status']}), cost rel diff max {ipopt['cost_rel_diff_vs_kkt_max']:.1e};"
          f" constant-derivative options "
          f"{res['ipopt_constant_derivatives']['per_problem']['median_s'] * 1e3:.2f} ms/problem",
          flush=True)

    # 4. peer B: scipy.sparse direct solve of the same KKT system ---------------------------------
    kkt = SparseKKT(D)
    orderings = {"spsolve": lambda K, r: spla.spsolve(K, r),            # SuperLU, COLAMD
                 "splu_natural": lambda K, r: spla.splu(K, permc_spec="NATURAL").solve(r)}
    spsolve = dict(problems=len(idx), kkt_size=kkt.size,
                   note="assembly: fixed CSC pattern, e-dependent diagonals filled per problem")
    for label, solve_fn in orderings.items():
        asm, sol_t, tot, rel, state = [], [], [], [], []
        for i in idx:
            t0 = time.perf_counter()
            K, rhs = kkt.assemble(w, data["rho"][i], data["half"][i], data["X0"][i],
                                  data["XT"][i])
            t1 = time.perf_counter()
            z = solve_fn(K, rhs)
            t2 = time.perf_counter()
            Q, V, U = (z[k * 3 * n:(k + 1) * 3 * n].reshape(3, n).T for k in range(3))
            cost = th_cost(U, w, data["rho"][i], data["half"][i]) * data["k2"][i] ** 4
            asm.append(t1 - t0), sol_t.append(t2 - t1), tot.append(t2 - t0)
            rel.append(abs(cost - ckk[i]) / abs(ckk[i]))
            state.append(rel_state_err(i, Q, V))
        u_si = data["k2"][idx[-1]] ** 2 * U
        spsolve[label] = dict(
            assembly=dict(median_s=statistics.median(asm)),
            solve=dict(median_s=statistics.median(sol_t), min_s=min(sol_t)),
            per_problem=dict(median_s=statistics.median(tot), min_s=min(tot)),
            problems_per_s=1.0 / statistics.median(tot),
            problems_per_s_solve_only=1.0 / statistics.median(sol_t),
            cost_rel_diff_vs_kkt_max=max(rel), cost_rel_diff_vs_kkt_median=statistics.median(rel),
            state_rel_diff_vs_kkt_max=max(state),
            control_rel_diff_vs_kkt_last=float(
                np.max(np.abs(u_si - kkt_U_si[idx[-1]])) / np.max(np.abs(u_si))))
    spsolve["kkt_nnz"] = int(K.nnz)
    best = min(orderings, key=lambda k: spsolve[k]["per_problem"]["median_s"])
    spsolve["floor"] = best
    res["scipy_sparse"] = spsolve
    for label in orderings:
        x = spsolve[label]
        print(f"[scipy {label}] assembly {x['assembly']['median_s'] * 1e3:.3f} ms + solve "
              f"{x['solve']['median_s'] * 1e3:.2f} ms per problem, cost rel diff max "
              f"{x['cost_rel_diff_vs_kkt_max']:.1e}", flush=True)

    # 5. STM law breakdown (where its time goes; vmapped over the batch) ------------------------
    res["stm_profile"] = stm_profile(probs, grid, args.batch)

    # ratios ----------------------------------------------------------------------------------
    ratios = {}
    floor = spsolve[spsolve["floor"]]
    tuned = res["ipopt_constant_derivatives"]
    for name in LAWS:
        pps = batched[name]["problems_per_s"]
        r = pps / ipopt["problems_per_s"]
        ratios[name] = dict(
            batched_vs_ipopt=r, goal=GOALS[name], goal_met=bool(r >= GOALS[name]),
            batched_vs_ipopt_constant_derivatives=pps / tuned["problems_per_s"],
            batched_vs_scipy_floor_assembly_and_solve=pps / floor["problems_per_s"],
            batched_vs_scipy_floor_solve_only=pps / floor["problems_per_s_solve_only"],
            batched_vs_scipy_spsolve=pps / spsolve["spsolve"]["problems_per_s"],
            single_vs_ipopt=ipopt["per_problem"]["median_s"] / single[name]["solve"]["median_s"],
            needed_problems_per_s=GOALS[name] * ipopt["problems_per_s"])
    res["ratios"] = ratios
    res["machine"]["loadavg_end"] = os.getloadavg()
    res["total_runtime_s"] = time.perf_counter() - t_start
    res["command"] = " ".join([os.path.basename(sys.executable)] + sys.argv)

    print_table(res)
    os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
    with open(args.out, "w") as fh:
        json.dump(res, fh, indent=2, default=float)
    print(f"\nwrote {args.out} (total {res['total_runtime_s']:.0f} s)")
    return res


def stm_profile(probs, grid, batch):
    """Batched time of pieces of the STM law, each jitted alone, calling the library's own
    functions (no copy of the law): the prelude; the law's cost alone (not writing the nodal
    arrays, though it still computes them: the cost is zeroed unless every output is
    finite); and the whole Solution as `jax.vmap` returns it (the grid, a leafless pytree, is
    not copied into the members)."""
    stages = {
        "_setup (Kepler solve, node times, TH boundary states)":
            lambda p: {k: v for k, v in _setup(p, grid).items() if k != "prob"},
        "stm_law, cost only": lambda p: stm_law(p, grid).cost,
        "stm_law, full Solution": lambda p: stm_law(p, grid),
    }
    out = {}
    for label, fn in stages.items():
        f = jax.jit(jax.vmap(fn))
        block(f(probs))
        t = timed(lambda: block(f(probs)), min_repeats=5, budget_s=1.5)
        out[label] = dict(batch_median_s=t["median_s"], per_problem_us=t["median_s"] / batch * 1e6)
    return out


def print_table(res):
    s, b, ip, sc, r = (res["single"], res["batched"], res["ipopt"], res["scipy_sparse"],
                       res["ratios"])
    ipc = res["ipopt_constant_derivatives"]
    bn = res["case"]["batch"]
    ms = 1e3
    print("\n=== LQ laws, LGL N = 64 (65 nodes), 3D, float64, "
          f"{res['machine']['nproc']} cores ({res['machine']['cpu_model']}) ===")
    print(f"{'solver':<38}{'compile/build':>14}{'steady-state time':>24}{'problems/s':>12}")
    for name in LAWS:
        print(f"{name + '_law, one problem (e=0.3)':<38}{s[name]['compile']['total_s']:>12.2f} s"
              f"{s[name]['solve']['median_s'] * ms:>15.3f} ms/prob"
              f"{1.0 / s[name]['solve']['median_s']:>12.0f}")
    for name in LAWS:
        print(f"{name + f'_law, jit(vmap) x{bn}':<38}{b[name]['compile']['total_s']:>12.2f} s"
              f"{b[name]['batch']['median_s'] * ms:>14.1f} ms/batch"
              f"{b[name]['problems_per_s']:>12.0f}   status 0: {b[name]['converged']}/{bn}")
    for label, x in (("CasADi+IPOPT (defaults)", ip),
                     ("CasADi+IPOPT (constant derivatives)", ipc)):
        print(f"{label:<38}{x['build_s']:>12.2f} s{x['per_problem']['median_s'] * ms:>15.3f} "
              f"ms/prob{x['problems_per_s']:>12.1f}")
    for label in ("spsolve", "splu_natural"):
        x = sc[label]
        print(f"{'scipy ' + label + ' (assembly+solve)':<38}{'-':>14}"
              f"{x['per_problem']['median_s'] * ms:>15.3f} ms/prob{x['problems_per_s']:>12.1f}")
        print(f"{'scipy ' + label + ' (solve only)':<38}{'-':>14}"
              f"{x['solve']['median_s'] * ms:>15.3f} ms/prob"
              f"{x['problems_per_s_solve_only']:>12.1f}")
    print("\nagreement with kkt_law cost_true_anomaly (max relative difference): "
          f"IPOPT {ip['cost_rel_diff_vs_kkt_max']:.1e} (IPOPT tol 1e-8), scipy "
          f"{sc['spsolve']['cost_rel_diff_vs_kkt_max']:.1e}, stm_law (its own discretisation) "
          f"{b['stm_vs_kkt_cost_max_rel_diff']:.1e}")
    print("\nratio (batched problems/s) / (peer problems/s):")
    for name in LAWS:
        x = r[name]
        print(f"  {name}: vs IPOPT {x['batched_vs_ipopt']:.1f}x (goal >= {x['goal']:.0f}x: "
              f"{'MET' if x['goal_met'] else 'NOT MET'}; needs {x['needed_problems_per_s']:.0f}"
              f" problems/s), vs IPOPT const-deriv "
              f"{x['batched_vs_ipopt_constant_derivatives']:.1f}x, vs scipy floor ("
              f"{sc['floor']}) {x['batched_vs_scipy_floor_assembly_and_solve']:.1f}x, "
              f"solve only {x['batched_vs_scipy_floor_solve_only']:.1f}x")
    print(f"\nSTM law breakdown (jit(vmap) x{bn}, per problem):")
    for label, v in res["stm_profile"].items():
        print(f"  {label:<56}{v['per_problem_us']:>9.1f} us")


if __name__ == "__main__":
    main()
