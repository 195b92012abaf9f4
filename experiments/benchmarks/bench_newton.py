"""Benchmark of the nonlinear Newton-KKT transfer solver against CasADi + IPOPT (issue 3).

The NLP: `newton_transfer(problem, lgl(65))` on `EnergyOptimalTransfer(..., model="two-body")`,
i.e. the LGL N = 64 transcription of jaxlpm.problems.energy_optimal / transcription: scaled LVLH
state X (65 x 6), scaled control U (65 x 3), true anomaly as the independent variable, exact
nonlinear relative dynamics with the chief's frame motion sampled once per node,
  defects   D X - h F(X_i, U_i)  (65 x 6, row-major),  boundary  [X_0 - x0, X_64 - xf],
  cost      h sum_i w_i q_i |U_i|^2 / 2,
585 unknowns and 402 equality constraints.

Peer: the SAME NLP written symbolically in CasADi (SX) and solved by IPOPT (MUMPS, exact
Hessian, tol 1e-10). CasADi gets jaxlpm's numbers, not its code paths: the chief's node data
(r_c, C, w, w_dot, q), the scalings L and n, h = (sf - s0)/2, the scaled boundary states, D and
the LGL weights are evaluated with JAX once per problem (outside IPOPT's timing) and enter the
CasADi NLP as parameters (the solver is built once); the dynamics, defects, boundary rows and
cost are written out again in CasADi. Both solvers start from the same point (jaxlpm's warm
start: the linear model's KKT solution mapped to the LVLH state) and IPOPT from zero
multipliers. The identity of the two NLPs is checked by evaluating both constraint functions
and objectives at the warm start, and the agreement of the optima by cost, controls and our own
KKT residual at IPOPT's (z, lambda).

Measured:
  1. single problem (mei2010 on the two-body model): our cold compile (lower + compile of
     jax.jit(newton_transfer), caches cleared, persistent cache off), our steady-state time
     (median of repeats), IPOPT's build time (nlpsol) and time per solve (median of repeats);
  2. batched: jax.jit(jax.vmap(newton_transfer, in_axes=(0, None))) over B dispersed problems
     (--batches), and --mapped M problems in one jitted call that runs lax.map over vmapped
     groups of --map-width (a vmapped while-loop runs every member for the slowest one's
     iterations; the map does not)
     (`jaxlpm.cases.mei2010.dispersion(PRNGKey(seed), B, "two-body")`: chief perigee altitude
     600 km, e in [0, 0.7], 1-5 revolutions, f0 and argp uniform, x0 position in a +-25 km cube,
     velocity +-10 m/s, xf = 0), compile and time per batch, convergence counts; IPOPT one
     problem at a time over
     the first --n-ipopt members of the largest batch (the same problems; all of them with
     --n-ipopt 1024). Throughput is problems per second of solving: ours B / (one batched
     call), IPOPT's n / (the sum of its n solve times); the rate of IPOPT's median solve
     (1 / median) is reported beside it;
  3. a profile of one solve: problem setup, warm start, derivative assembly, the KKT solve
     (dense: Jacobian, Hessian, the 987 x 987 LU; condensed: drift Jacobians and the null-space
     map T, Hessian blocks, the 183 x 183 reduced system), and iteration counts.
--linear-algebra picks newton_transfer's KKT solve ("auto" = "condensed" here, or "dense").

Wall and process CPU times are both recorded (the machine is shared: CPU time depends less on
the other processes' load). A batched call is timed once when it takes longer than
--batch-one-call-s (the AOT-compiled executable: no compile inside).

Run:  PYTHONPATH=. python experiments/benchmarks/bench_newton.py [--batches 64]
      [--mapped 1024 --map-width 1] [--n-ipopt 1024] [--linear-algebra auto]
      [--out results/bench_newton.json]
(with --linear-algebra dense, --batches 1024 does not fit: one copy of the batched 987 x 987
KKT matrices is 8 GB; see BENCHMARKS.md)
"""

import argparse
import functools
import json
import os
import statistics
import sys
import time

# jaxlpm sets its CPU runtime at import (one OpenBLAS thread, XLA's sequential CPU scheduler):
# import it before numpy/scipy/casadi so every solver runs under the same settings.
from jaxlpm import lgl  # noqa: E402

import faulthandler  # noqa: E402

import jax  # noqa: E402

jax.config.update("jax_enable_x64", True)
jax.config.update("jax_enable_compilation_cache", False)   # cold compiles, measured

import casadi as ca  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from jaxlpm.batch import map_in_groups  # noqa: E402
from jaxlpm.cases import mei2010  # noqa: E402
from jaxlpm.problems.energy_optimal import control_scale, cost_scale, transfer_ocp  # noqa: E402
from jaxlpm.nlp.transcription import (equality, equality_jacobian,  # noqa: E402
                                           lagrangian_hessian, objective)
from jaxlpm.nlp.condensed import CondensedSecondOrder  # noqa: E402
from jaxlpm.nlp.newton import _kkt_step, kkt_residual  # noqa: E402
# newton_transfer: the solver behind solve(..., method="newton"), called directly for its
# linear_algebra choice (not an option of the public entry point)
from jaxlpm.solvers.transfer import _warm_start, newton_transfer  # noqa: E402
from common import block, cold_compile, machine_info, timed  # noqa: E402  (this directory)

N_POINTS = 65                 # LGL N = 64
MODEL = "two-body"
IPOPT_OPTIONS = {"ipopt.tol": 1e-10, "ipopt.print_level": 0, "ipopt.sb": "yes",
                 "ipopt.hessian_approximation": "exact", "ipopt.linear_solver": "mumps",
                 "print_time": False}
TARGETS = dict(single_time_ratio_max=0.5,        # ours / IPOPT's, one problem
               batched_throughput_ratio_min=10.0,  # ours batched problems/s / IPOPT's
               compile_s_max=15.0)


# ----------------------------------------------------------------------------------- helpers
def single_problem():
    return mei2010.problem().replace(model=MODEL)


def dispersion(key, n):
    """mei2010's dispersion (its case's) on the two-body model, and its name."""
    return mei2010.dispersion(key, n, MODEL), "jaxlpm.cases.mei2010.dispersion"


def take(tree, i):
    return jax.tree.map(lambda x: x[i], tree)


# ---------------------------------------------------------------- numbers shared with CasADi
@jax.jit
def peer_data(problem, grid):
    """Everything CasADi needs for one problem on `grid` (an LGL grid or an `LGRMesh`),
    evaluated by jaxlpm once: node data, scalings, h, scaled boundary states, our warm start
    z0, and the SI scalings of cost and control."""
    ocp, _, ok = transfer_ocp(problem, grid)
    r, (C, w, wd), q = ocp.node_data
    P = ocp.params
    z0, _ = _warm_start(problem, ocp, grid)
    node = jnp.concatenate([r, C.reshape(-1, 9), w, wd, q[:, None]], axis=1)      # (n, 19)
    glob = jnp.concatenate([jnp.stack([P["length"], P["n"], P["mu"], 0.5 * (ocp.sf - ocp.s0)]),
                            P["x0"], P["xf"]])                                     # (16,)
    # the two-body models leave J2 out of the program (params["j2"] None): J2 = 0 for CasADi
    j2 = jnp.zeros_like(P["mu"]) if P["j2"] is None else P["j2"]
    return dict(p=jnp.concatenate([node.reshape(-1), glob]), z0=z0, ok=ok,
                j2=j2, cost_scale=cost_scale(problem),
                control_scale=control_scale(problem))


def host(d):
    return {k: np.asarray(v) for k, v in d.items()}


# --------------------------------------------------------------------- the NLP in CasADi (SX)
def _inv_pow_diff(R, r, dR, n):
    """1/R^n - 1/r^n without cancellation (dR = R - r formed stably)."""
    return -dR * sum(R**k * r ** (n - 1 - k) for k in range(n)) / (R * r) ** n


def build_ipopt(D, weights, options=IPOPT_OPTIONS):
    """CasADi NLP of the transcription, parameters p = [per node (r_c 3, C row-major 9, w 3,
    w_dot 3, q 1) x n, L, n_mean, mu, h, x0 (6), xf (6)]; built once, solved per problem.
    D (n, n_rows): the grid's differentiation matrix, square for LGL, (K m, K m + 1) for an
    LGR mesh (its state rows are the collocation points and the end).

    Decision vector z = [X row-major (n_rows x 6), U row-major (n x 3)], constraints [defects
    row-major (n x 6), X_0 - x0, X_last - xf]: the same order as jaxlpm's `pack`/`equality`,
    so z0 and the multipliers carry over unchanged.

    Dynamics (jaxlpm.problems.energy_optimal, model "two-body"): x_si = [L rho~, L n rho_dot~],
    u_si = L n^2 u~, rho_ddot = C (a(r_c + C^T rho) - a(r_c)) + u_si - 2 w x rho_dot
    - w_dot x rho - w x (w x rho) with the two-body gravity difference in Encke form, and
    F = q [rho_dot~, rho_ddot / (L n^2)]. (jaxlpm's function also has J2 terms, multiplied by
    j2 = 0 for this model; they are left out here: the same function.)
    """
    n, n_rows = D.shape
    z = ca.SX.sym("z", 6 * n_rows + 3 * n)
    Xt = ca.reshape(z[:6 * n_rows], 6, n_rows)   # column i = x_i (CasADi reshape: column-major)
    Ut = ca.reshape(z[6 * n_rows:], 3, n)
    node = ca.SX.sym("node", 19, n)
    glob = ca.SX.sym("glob", 16)
    L, nm, mu, h = glob[0], glob[1], glob[2], glob[3]
    x0, xf = glob[4:10], glob[10:16]
    F_cols, cost = [], 0
    for i in range(n):
        col = node[:, i]
        rc = col[0:3]
        C = ca.reshape(col[3:12], 3, 3).T     # row-major 9 -> C
        w, wd, q = col[12:15], col[15:18], col[18]
        x, u = Xt[:, i], Ut[:, i]
        rho, rho_dot = L * x[0:3], (L * nm) * x[3:6]
        u_si = (L * nm * nm) * u
        dr = ca.mtimes(C.T, rho)
        rn = ca.norm_2(rc)
        rp = rc + dr
        Rn = ca.norm_2(rp)
        dR = (2.0 * ca.dot(rc, dr) + ca.dot(dr, dr)) / (Rn + rn)
        da = -mu * (dr / Rn**3 + rc * _inv_pow_diff(Rn, rn, dR, 3))
        acc = (ca.mtimes(C, da) + u_si - 2.0 * ca.cross(w, rho_dot) - ca.cross(wd, rho)
               - ca.cross(w, ca.cross(w, rho)))
        F_cols.append(q * ca.vertcat(x[3:6], acc / (L * nm * nm)))
        cost = cost + float(weights[i]) * 0.5 * q * ca.sumsqr(u)
    Ft = ca.horzcat(*F_cols)
    defects = ca.mtimes(Xt, ca.DM(D.T)) - h * Ft                       # (6, n) = (D X - hF)^T
    g = ca.vertcat(ca.vec(defects), Xt[:, 0] - x0, Xt[:, n_rows - 1] - xf)
    nlp = dict(x=z, p=ca.vertcat(ca.vec(node), glob), f=h * cost, g=g)
    t0 = time.perf_counter()
    solver = ca.nlpsol("newton_peer", "ipopt", nlp, dict(options))
    build_s = time.perf_counter() - t0
    funcs = ca.Function("nlp_fg", [nlp["x"], nlp["p"]], [nlp["f"], nlp["g"]])
    return solver, funcs, build_s, (z.numel(), g.numel())


def ipopt_solve(solver, d):
    t0, c0 = time.perf_counter(), time.process_time()
    out = solver(x0=d["z0"], p=d["p"], lbg=0.0, ubg=0.0)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    st = solver.stats()
    return dict(z=np.asarray(out["x"]).ravel(), lam=np.asarray(out["lam_g"]).ravel(),
                f=float(out["f"]), wall_s=wall, cpu_s=cpu, status=st["return_status"],
                success=bool(st["success"]), iterations=int(st["iter_count"]),
                t_wall_nlp_functions=float(sum(v for k, v in st.items()
                                               if k.startswith("t_wall_nlp_"))))


# ------------------------------------------------------------------------- KKT residuals etc.
@jax.jit
def own_kkt_residuals(problem, z, lam, grid=None):
    """max |c| and max |grad_z L| of OUR transcription at (z, lambda) (scaled units), on
    `grid` (default lgl(N_POINTS))."""
    grid = lgl(N_POINTS) if grid is None else grid
    ocp, _, _ = transfer_ocp(problem, grid)
    r = kkt_residual(jnp.concatenate([z, lam]), ocp, grid)
    n = z.size
    return jnp.max(jnp.abs(r[n:])), jnp.max(jnp.abs(r[:n]))


def compare(ours_cost, ours_u, ip, d):
    """Cost and control differences between our solution (SI) and IPOPT's (scaled -> SI)."""
    n = ours_u.shape[0]
    u_ip = ip["z"][-3 * n:].reshape(n, 3) * float(d["control_scale"])
    cost_ip = ip["f"] * float(d["cost_scale"])
    du = float(np.max(np.abs(u_ip - ours_u)))
    return dict(cost_ours=float(ours_cost), cost_ipopt=cost_ip,
                cost_rel_diff=abs(cost_ip - float(ours_cost)) / abs(float(ours_cost)),
                control_max_abs_diff_m_s2=du,
                control_max_rel_diff=du / float(np.max(np.abs(ours_u))))


# ----------------------------------------------------------------------------------- profile
def time_pieces(pieces):
    """{label: median seconds} of each (fn, args) jitted alone."""
    out = {}
    for label, (fn, args) in pieces.items():
        f = jax.jit(fn)
        block(f(*args))
        out[label] = timed(lambda: block(f(*args)), min_repeats=5, budget_s=1.5)["median_s"]
    return out


def profile(prob, grid, sol):
    """Time the pieces of one solve, each jitted alone on the converged problem's data."""
    ocp, _, _ = transfer_ocp(prob, grid)
    z0, _ = _warm_start(prob, ocp, grid)
    lam = jnp.zeros(equality(z0, ocp, grid).shape)
    H = lagrangian_hessian(z0, lam, ocp, grid)
    A = equality_jacobian(z0, ocp, grid)
    g = jax.grad(objective)(z0, ocp, grid)
    c = equality(z0, ocp, grid)
    pieces = {
        "transfer_ocp (Kepler, chief node data)": (lambda p: transfer_ocp(p, grid)[0], (prob,)),
        "transfer_ocp + _warm_start (one dense 987 KKT solve of the linear model)":
            (lambda p: _warm_start(p, transfer_ocp(p, grid)[0], grid), (prob,)),
        "kkt_residual (grad L by autodiff, c)":
            (lambda z, l: kkt_residual(jnp.concatenate([z, l]), ocp, grid), (z0, lam)),
        "equality_jacobian (A, 402 x 585)": (lambda z: equality_jacobian(z, ocp, grid), (z0,)),
        "lagrangian_hessian (H, 585 x 585)":
            (lambda z, l: lagrangian_hessian(z, l, ocp, grid), (z0, lam)),
        "_kkt_step (form K 987 x 987 + jnp.linalg.solve)":
            (lambda H, A, g, c: _kkt_step(H, A, g, c, 0.0, 0.0), (H, A, g, c)),
        "jax.scipy.linalg.lu_factor (987 x 987) alone":
            (lambda H, A: jax.scipy.linalg.lu_factor(
                jnp.block([[H, A.T], [A, jnp.zeros((A.shape[0],) * 2)]])), (H, A)),
    }
    out = time_pieces(pieces)
    it = int(sol.stats["iterations"])
    # every loop pass (iterations + the final pass that detects convergence) assembles H and A
    # and solves the KKT system once (more on a regularisation retry): sum the pieces
    per_pass = (out["kkt_residual (grad L by autodiff, c)"] * 2     # residuals + watchdog
                + out["equality_jacobian (A, 402 x 585)"]
                + out["lagrangian_hessian (H, 585 x 585)"]
                + out["_kkt_step (form K 987 x 987 + jnp.linalg.solve)"])
    passes = it + 1
    est = out["transfer_ocp + _warm_start (one dense 987 KKT solve of the linear model)"] + \
        passes * per_pass
    n_solves = 1 + passes
    dense = n_solves * out["_kkt_step (form K 987 x 987 + jnp.linalg.solve)"]
    return dict(pieces_s=out, newton_iterations=it, loop_passes=passes,
                dense_kkt_solves=n_solves, estimated_total_s=est,
                estimated_dense_solve_s=dense, estimated_dense_solve_fraction=dense / est)


def batched_lu(B, grid, prob):
    """Per-member time of a vmapped 987 x 987 LU (does batching help the dense solve?)."""
    ocp, _, _ = transfer_ocp(prob, grid)
    z0, _ = _warm_start(prob, ocp, grid)
    lam = jnp.zeros(equality(z0, ocp, grid).shape)
    H = lagrangian_hessian(z0, lam, ocp, grid)
    A = equality_jacobian(z0, ocp, grid)
    K = jnp.block([[H, A.T], [A, jnp.zeros((A.shape[0],) * 2)]])
    Kb = jnp.broadcast_to(K, (B,) + K.shape) + 0.0
    f = jax.jit(jax.vmap(jax.scipy.linalg.lu_factor))
    block(f(Kb))
    t = timed(lambda: block(f(Kb)), min_repeats=3, budget_s=3.0)
    return dict(batch=B, per_member_s=t["median_s"] / B)


def profile_condensed(prob, grid, sol):
    """Time the pieces of one condensed solve, each jitted alone at the warm start."""
    ocp, _, _ = transfer_ocp(prob, grid)
    z0, _ = _warm_start(prob, ocp, grid)
    la = CondensedSecondOrder(ocp, grid)
    lam = la.first_multipliers(z0)
    prep = la.prepare(z0, lam)
    H = la.hessian(prep, z0, lam)
    g = jax.grad(objective)(z0, ocp, grid)
    c = equality(z0, ocp, grid)

    def with_la(fn):
        return lambda *a: fn(CondensedSecondOrder(ocp, grid), *a)

    pieces = {
        "transfer_ocp (Kepler, chief node data)": (lambda p: transfer_ocp(p, grid)[0], (prob,)),
        "transfer_ocp + _warm_start (kkt_law of the linear model)":
            (lambda p: _warm_start(p, transfer_ocp(p, grid)[0], grid), (prob,)),
        "kkt_residual (grad L by autodiff, c)":
            (lambda z, l: kkt_residual(jnp.concatenate([z, l]), ocp, grid), (z0, lam)),
        "prepare (Jacobians, null-space basis)":
            (with_la(lambda la, z, l: la.prepare(z, l)), (z0, lam)),
        "hessian (null-space map T 585 x 183, point blocks, T^T H T)":
            (with_la(lambda la, pr, z, l: la.hessian(pr, z, l)), (prep, z0, lam)),
        "solve (183 x 183 Cholesky, multipliers)":
            (with_la(lambda la, pr, H, g, c: la.solve(pr, H, g, c, 0.0, 0.0)), (prep, H, g, c)),
    }
    out = time_pieces(pieces)
    it = int(sol.stats["iterations"])
    per_pass = sum(v for k, v in out.items() if k.startswith(("kkt", "prepare", "hessian",
                                                              "solve")))
    passes = it + 1
    est = out["transfer_ocp + _warm_start (kkt_law of the linear model)"] + passes * per_pass
    return dict(pieces_s=out, newton_iterations=it, loop_passes=passes, estimated_total_s=est)


# ----------------------------------------------------------------------------------- machine
# -------------------------------------------------------------------------------------- main
def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="results/bench_newton.json")
    ap.add_argument("--batches", default="64",
                    help="comma-separated batch sizes for jit(vmap(newton_transfer)); a call "
                         "runs every member for the batch's largest iteration count")
    ap.add_argument("--mapped", type=int, default=1024,
                    help="problems solved in one jitted call by lax.map over vmapped groups "
                         "(0: skip)")
    ap.add_argument("--map-width", type=int, default=1, help="vmap width inside that lax.map")
    ap.add_argument("--linear-algebra", default="auto", choices=("auto", "condensed", "dense"),
                    help="newton_transfer's KKT solve")
    ap.add_argument("--n-ipopt", type=int, default=1024,
                    help="dispersed problems solved one at a time by IPOPT")
    ap.add_argument("--single-repeats-s", type=float, default=6.0,
                    help="time budget for the single-problem repeats (each solver)")
    ap.add_argument("--batch-budget-s", type=float, default=1.0,
                    help="extra repeats of a batched call while within this budget (>= 2 calls"
                         " unless the first took longer than --batch-one-call-s)")
    ap.add_argument("--batch-one-call-s", type=float, default=60.0)
    ap.add_argument("--no-opt0", action="store_true",
                    help="skip the compile at XLA backend optimisation level 0 (diagnostic)")
    ap.add_argument("--compile-repeats", type=int, default=1)
    ap.add_argument("--no-profile", action="store_true")
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--watchdog", type=float, default=3600.0,
                    help="abort with a traceback after this many seconds (a hung XLA pool)")
    args = ap.parse_args(argv)
    batches = [int(b) for b in args.batches.split(",") if b]
    newton = functools.partial(newton_transfer, linear_algebra=args.linear_algebra)
    faulthandler.dump_traceback_later(args.watchdog, exit=True)
    t_start = time.perf_counter()
    grid = lgl(N_POINTS)
    D, W = np.asarray(grid.D), np.asarray(grid.weights)
    res = dict(schema_version=1, linear_algebra=args.linear_algebra, date_utc=time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
               case=dict(single="mei2010 (a 9500 km, e 0.3, 3 rev, x0 [10 km, 10 km, 0, 4, "
                         "-23.485, 0]) on model two-body", lgl_points=N_POINTS,
                         N=N_POINTS - 1, model=MODEL, variables=9 * N_POINTS,
                         constraints=6 * N_POINTS + 12,
                         dispersion=dict(perigee_altitude_m=mei2010.PERIGEE_ALTITUDE,
                                         e=mei2010.E_RANGE,
                                         revolutions=mei2010.REVOLUTIONS_RANGE,
                                         f0="U[0, 2 pi)",
                                         x0_position_box_m=mei2010.POSITION_HALF_WIDTH,
                                         x0_velocity_box_m_s=mei2010.VELOCITY_HALF_WIDTH,
                                         xf="0", seed=args.seed)),
               targets=TARGETS, machine=machine_info(casadi=ca.__version__),
               ipopt_options=IPOPT_OPTIONS)

    # 1. single problem: ours ----------------------------------------------------------------
    prob = single_problem()
    compiled, comp = cold_compile(newton, prob, grid, repeats=args.compile_repeats)
    sol = block(compiled(prob, grid))
    run = timed(lambda: block(compiled(prob, grid)), min_repeats=10,
                budget_s=args.single_repeats_s)
    run["loadavg"] = os.getloadavg()
    st = sol.stats
    ours = dict(compile=comp, solve=run, status=int(sol.status), iterations=int(st["iterations"]),
                cost_m2_s3=float(sol.cost), constraint_residual=float(st["constraint_residual"]),
                stationarity_residual=float(st["stationarity_residual"]),
                history=[float(h) for h in np.asarray(st["history"])[:int(st["iterations"]) + 1]])
    if not args.no_opt0:
        # diagnostic: the same function with LLVM's backend optimisation off (as the mei2010
        # CLI does for the LQ laws): how much of the compile is LLVM, and what it costs at run
        c0_exec, comp0 = cold_compile(newton, prob, grid,
                                      compiler_options={"xla_backend_optimization_level": 0})
        block(c0_exec(prob, grid))
        ours_opt0 = dict(compile=comp0, solve=timed(lambda: block(c0_exec(prob, grid)),
                                                    min_repeats=5, budget_s=2.0))
        del c0_exec
    print(f"[ours, single] compile {comp['total_s']:.1f} s (lower {comp['lower_s']:.1f} + "
          f"compile {comp['compile_s']:.1f}), solve {run['median_s'] * 1e3:.1f} ms (median of "
          f"{run['repeats']}), status {ours['status']}, {ours['iterations']} iterations, "
          f"load {run['loadavg'][0]:.2f}", flush=True)
    if not args.no_opt0:
        ours["backend_opt_level_0"] = ours_opt0
        print(f"[ours, single, XLA backend opt level 0] compile "
              f"{ours_opt0['compile']['total_s']:.1f} s, solve "
              f"{ours_opt0['solve']['median_s'] * 1e3:.1f} ms", flush=True)

    # 1. single problem: IPOPT ---------------------------------------------------------------
    solver, funcs, build_s, (nv, nc) = build_ipopt(D, W)
    d = host(peer_data(prob, grid))
    # the two NLPs are the same function: compare at the common starting point
    ocp, _, _ = transfer_ocp(prob, grid)
    f_ca, g_ca = funcs(d["z0"], d["p"])
    c_ours = np.asarray(equality(jnp.asarray(d["z0"]), ocp, grid))
    f_ours = float(objective(jnp.asarray(d["z0"]), ocp, grid))
    same_nlp = dict(constraint_max_abs_diff_at_z0=float(np.max(np.abs(np.asarray(g_ca).ravel()
                                                                     - c_ours))),
                    constraint_max_abs_at_z0=float(np.max(np.abs(c_ours))),
                    objective_rel_diff_at_z0=abs(float(f_ca) - f_ours) / abs(f_ours))
    first = ipopt_solve(solver, d)
    ip_runs = [first]
    t0 = time.perf_counter()
    while len(ip_runs) < 10 or (time.perf_counter() - t0 < args.single_repeats_s
                                and len(ip_runs) < 200):
        ip_runs.append(ipopt_solve(solver, d))
    times = [r["wall_s"] for r in ip_runs[1:]]
    ip = ip_runs[-1]
    kc, kg = own_kkt_residuals(prob, jnp.asarray(ip["z"]), jnp.asarray(ip["lam"]))
    ipopt_single = dict(build_s=build_s, first_solve_s=first["wall_s"], variables=nv,
                        constraints=nc,
                        solve=dict(median_s=statistics.median(times), min_s=min(times),
                                   repeats=len(times), loadavg=os.getloadavg(),
                                   cpu_median_s=statistics.median(
                                       r["cpu_s"] for r in ip_runs[1:])),
                        casadi_function_evaluations_median_s=statistics.median(
                            r["t_wall_nlp_functions"] for r in ip_runs[1:]),
                        status=ip["status"], iterations=ip["iterations"],
                        own_kkt_constraint_residual=float(kc),
                        own_kkt_stationarity_residual=float(kg),
                        same_nlp_check=same_nlp,
                        agreement=compare(sol.cost, np.asarray(sol.node_controls), ip, d))
    res["single"] = dict(ours=ours, ipopt=ipopt_single,
                         time_ratio_ours_over_ipopt=run["median_s"]
                         / ipopt_single["solve"]["median_s"])
    a = ipopt_single["agreement"]
    print(f"[ipopt, single] build {build_s:.2f} s, solve "
          f"{ipopt_single['solve']['median_s'] * 1e3:.1f} ms (median of {len(times)}), "
          f"{ip['status']}, {ip['iterations']} iterations; same NLP at z0: |dc| "
          f"{same_nlp['constraint_max_abs_diff_at_z0']:.1e}; optimum: cost rel diff "
          f"{a['cost_rel_diff']:.1e}, max |du| {a['control_max_abs_diff_m_s2']:.1e} m/s^2 "
          f"({a['control_max_rel_diff']:.1e} rel)", flush=True)

    # 2. batched -----------------------------------------------------------------------------
    key = jax.random.PRNGKey(args.seed)
    res["batched"] = {}
    vsolve = jax.vmap(newton, in_axes=(0, None))

    def mapped(ps, g):       # width 1: one problem at a time, not vmapped
        return map_in_groups(lambda p: newton(p, g), ps, args.map_width)

    runs = [(str(B), f"jit(vmap(newton_transfer)) x{B}", vsolve, B) for B in batches]
    if args.mapped:
        runs.append((f"map{args.mapped}_w{args.map_width}",
                     f"jit(lax.map, width {args.map_width}) x{args.mapped}", mapped, args.mapped))
    last = None
    for name, label, fn, B in runs:
        probs, sampler = dispersion(key, B)
        compiled_b, comp_b = cold_compile(fn, probs, grid)
        t0, c0 = time.perf_counter(), time.process_time()
        sols = block(compiled_b(probs, grid))
        calls, cpus = [time.perf_counter() - t0], [time.process_time() - c0]
        while (len(calls) < 2 and calls[0] < args.batch_one_call_s) or (
                len(calls) >= 2 and sum(calls[1:]) < args.batch_budget_s):
            t0, c0 = time.perf_counter(), time.process_time()
            block(compiled_b(probs, grid))
            calls.append(time.perf_counter() - t0)
            cpus.append(time.process_time() - c0)
        per_call = statistics.median(calls)
        status = np.asarray(sols.status)
        iters = np.asarray(sols.stats["iterations"])
        res["batched"][name] = dict(
            label=label, sampler=sampler, compile=comp_b, call_s=calls, call_cpu_s=cpus,
            median_call_s=per_call,
            per_problem_s=per_call / B, problems_per_s=B / per_call, loadavg=os.getloadavg(),
            converged=int(np.sum(status == 0)), members=B,
            status_counts={int(k): int(v) for k, v in zip(*np.unique(status, return_counts=True))},
            iterations_max=int(iters.max()), iterations_median=float(np.median(iters)),
            iterations_sum=int(iters.sum()))
        r = res["batched"][name]
        print(f"[ours, {label}] compile {comp_b['total_s']:.1f} s, call {per_call:.2f} s "
              f"({r['per_problem_s'] * 1e3:.1f} ms/problem, {r['problems_per_s']:.1f} "
              f"problems/s), status 0: {r['converged']}/{B}, iterations max "
              f"{r['iterations_max']}, load {r['loadavg'][0]:.2f}", flush=True)
        if last is None or B >= last[0]:
            last = (B, probs, sols)
        del compiled_b

    # IPOPT over a sample of the same dispersed problems (the first n of the largest batch;
    # every batch is a prefix-independent draw, so use the largest one's members)
    B, probs, sols = last
    m = min(args.n_ipopt, B)
    pdata = host(jax.jit(jax.vmap(peer_data, in_axes=(0, None)))(take(probs, slice(0, m)),
                                                                  grid))
    samples = []
    for i in range(m):
        di = {k: v[i] for k, v in pdata.items()}
        ipi = ipopt_solve(solver, di)
        kc, kg = own_kkt_residuals(take(probs, i), jnp.asarray(ipi["z"]),
                                   jnp.asarray(ipi["lam"]))
        ours_ok = int(sols.status[i]) == 0
        row = dict(member=i, e=float(probs.orbit.e[i]),
                   revolutions=float(probs.duration[i] / probs.orbit.period[i]),
                   ipopt_s=ipi["wall_s"], ipopt_cpu_s=ipi["cpu_s"],
                   ipopt_status=ipi["status"],
                   ipopt_iterations=ipi["iterations"], ours_status=int(sols.status[i]),
                   ours_iterations=int(sols.stats["iterations"][i]),
                   ipopt_own_kkt=(float(kc), float(kg)))
        if ipi["success"] and ours_ok:
            row.update(compare(sols.cost[i], np.asarray(sols.node_controls[i]), ipi, di))
        samples.append(row)
    ip_times = [r["ipopt_s"] for r in samples]
    ok_both = [r for r in samples if "cost_rel_diff" in r]
    ipopt_batch = dict(
        problems=m, from_batch=B, per_problem_median_s=statistics.median(ip_times),
        per_problem_mean_s=statistics.mean(ip_times),
        # throughput: problems solved one after another per second of IPOPT (what ours is:
        # problems per second of the batched call); the median's rate is reported beside it
        problems_per_s=m / sum(ip_times),
        problems_per_s_median=1.0 / statistics.median(ip_times),
        per_problem_cpu_median_s=statistics.median(r["ipopt_cpu_s"] for r in samples),
        succeeded=sum(r["ipopt_status"] == "Solve_Succeeded" for r in samples),
        ours_succeeded_same_members=sum(r["ours_status"] == 0 for r in samples),
        iterations=[r["ipopt_iterations"] for r in samples],
        cost_rel_diff_max=max((r["cost_rel_diff"] for r in ok_both), default=None),
        control_max_abs_diff_m_s2=max((r["control_max_abs_diff_m_s2"] for r in ok_both),
                                      default=None),
        control_max_rel_diff=max((r["control_max_rel_diff"] for r in ok_both), default=None),
        members=samples, loadavg=os.getloadavg())
    res["ipopt_dispersed"] = ipopt_batch
    print(f"[ipopt, dispersed] {m} problems: median {ipopt_batch['per_problem_median_s'] * 1e3:.1f}"
          f" ms/problem, mean {ipopt_batch['per_problem_mean_s'] * 1e3:.1f} ms, succeeded {ipopt_batch['succeeded']}/{m} (ours on the same: "
          f"{ipopt_batch['ours_succeeded_same_members']}/{m}), cost rel diff max "
          f"{ipopt_batch['cost_rel_diff_max']}, control rel diff max "
          f"{ipopt_batch['control_max_rel_diff']}", flush=True)

    # 3. profile -----------------------------------------------------------------------------
    if not args.no_profile:
        if args.linear_algebra == "dense":
            res["profile"] = profile(prob, grid, sol)
            res["profile"]["batched_lu_987"] = batched_lu(32, grid, prob)
        else:
            res["profile"] = profile_condensed(prob, grid, sol)
        res["profile"]["loadavg"] = os.getloadavg()

    # ratios and targets -----------------------------------------------------------------------
    single_ratio = res["single"]["time_ratio_ours_over_ipopt"]
    ratios = dict(single_time_ours_over_ipopt=single_ratio,
                  single_met=bool(single_ratio <= TARGETS["single_time_ratio_max"]),
                  compile_s=comp["total_s"],
                  compile_met=bool(comp["total_s"] <= TARGETS["compile_s_max"]),
                  batched={})
    for Bs, r in res["batched"].items():
        x = r["problems_per_s"] / ipopt_batch["problems_per_s"]
        ratios["batched"][Bs] = dict(
            throughput_ours_over_ipopt=x,
            over_ipopt_median_rate=r["problems_per_s"] / ipopt_batch["problems_per_s_median"],
            met=bool(x >= TARGETS["batched_throughput_ratio_min"]),
            vs_ipopt_single_mei2010=r["problems_per_s"] * ipopt_single["solve"]["median_s"])
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


def print_table(res):
    s, ip, r = res["single"], res["ipopt_dispersed"], res["ratios"]
    o, p = s["ours"], s["ipopt"]
    ms = 1e3
    print(f"\n=== Newton-KKT vs CasADi+IPOPT, LGL N = 64, model two-body, float64, "
          f"{res['machine']['nproc']} cores ({res['machine']['cpu_model']}), load "
          f"{res['machine']['loadavg_start'][0]:.1f} -> {res['machine']['loadavg_end'][0]:.1f} ===")
    print(f"{'solver':<42}{'compile/build':>15}{'wall':>18}{'CPU':>12}{'problems/s':>12}"
          f"  converged")
    print(f"{'newton_transfer, mei2010':<42}{o['compile']['total_s']:>9.1f} s wall"
          f"{o['solve']['median_s'] * ms:>13.1f} ms{o['solve']['cpu_median_s'] * ms:>9.1f} ms"
          f"{1 / o['solve']['median_s']:>12.2f}  status {o['status']}, {o['iterations']} it")
    if "backend_opt_level_0" in o:
        x = o["backend_opt_level_0"]
        print(f"{'  same, XLA backend opt level 0':<42}{x['compile']['total_s']:>9.1f} s wall"
              f"{x['solve']['median_s'] * ms:>13.1f} ms{x['solve']['cpu_median_s'] * ms:>9.1f} ms")
    print(f"{'CasADi+IPOPT, mei2010':<42}{p['build_s']:>9.2f} s wall"
          f"{p['solve']['median_s'] * ms:>13.1f} ms{p['solve']['cpu_median_s'] * ms:>9.1f} ms"
          f"{1 / p['solve']['median_s']:>12.2f}  {p['status']}, {p['iterations']} it")
    for B, b in res["batched"].items():
        cpu = statistics.median(b["call_cpu_s"]) / b["members"]
        print(f"{b['label'] + ' dispersed':<42}"
              f"{b['compile']['total_s']:>9.1f} s wall{b['per_problem_s'] * ms:>13.1f} ms"
              f"{cpu * ms:>9.1f} ms{b['problems_per_s']:>12.2f}  {b['converged']}/{b['members']}"
              f" (max {b['iterations_max']} it)")
    print(f"{'CasADi+IPOPT, ' + str(ip['problems']) + ' of the dispersed':<42}{'-':>15}"
          f"{ip['per_problem_median_s'] * ms:>13.1f} ms{ip['per_problem_cpu_median_s'] * ms:>9.1f}"
          f" ms{ip['problems_per_s']:>12.2f}  {ip['succeeded']}/{ip['problems']} (ours "
          f"{ip['ours_succeeded_same_members']}/{ip['problems']})")
    print(f"(compile CPU time {o['compile']['cpu_s']:.1f} s; times per problem, medians)")
    print(f"\nagreement (mei2010): cost rel diff {p['agreement']['cost_rel_diff']:.1e}, max |du| "
          f"{p['agreement']['control_max_abs_diff_m_s2']:.1e} m/s^2 "
          f"({p['agreement']['control_max_rel_diff']:.1e} of max |u|); dispersed sample "
          f"(members both solved): cost {ip['cost_rel_diff_max']}, controls "
          f"{ip['control_max_rel_diff']} (rel, max)")
    print(f"targets: single time ratio {r['single_time_ours_over_ipopt']:.2f} (<= 0.5: "
          f"{'MET' if r['single_met'] else 'NOT MET'}); compile {r['compile_s']:.1f} s (< 15 s: "
          f"{'MET' if r['compile_met'] else 'NOT MET'})")
    for B, x in r["batched"].items():
        print(f"  {res['batched'][B]['label']}: throughput {x['throughput_ours_over_ipopt']:.2f}x "
              f"IPOPT's (>= 10x: {'MET' if x['met'] else 'NOT MET'}; "
              f"{x['over_ipopt_median_rate']:.2f}x the rate of IPOPT's median solve)")
    if "profile" in res:
        pr = res["profile"]
        print(f"\nprofile (one mei2010 solve, pieces jitted alone; {pr['newton_iterations']} "
              f"Newton iterations, {pr['loop_passes']} loop passes):")
        for k, v in pr["pieces_s"].items():
            print(f"  {k:<74}{v * ms:>9.2f} ms")
        line = f"  estimated total {pr['estimated_total_s'] * ms:.1f} ms"
        if "batched_lu_987" in pr:
            line += (f", of which dense KKT solves {pr['estimated_dense_solve_s'] * ms:.1f} ms "
                     f"({pr['estimated_dense_solve_fraction'] * 100:.0f} %); vmapped LU x"
                     f"{pr['batched_lu_987']['batch']}: "
                     f"{pr['batched_lu_987']['per_member_s'] * ms:.1f} ms per member")
        print(line)


if __name__ == "__main__":
    main()
