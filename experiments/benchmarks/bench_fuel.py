"""Benchmark of the batched fuel-optimal solve on eccentric chiefs against CasADi + IPOPT one
problem at a time on the same transcription (issue 22).

The problems: a dispersion of B transfers on the linear (Tschauner-Hempel) model, chief
perigee radius 7000 km and e uniform in [0, 0.5], from rest at the chief to a point at rest
uniform in a box of +-4 km (radial, along-track) and +-1 km (normal), in 0.9-1.3 chief
periods, 0.3 N on 50 kg (u_max = 6 mm/s^2).

The transcription (both solvers): the fuel-optimal family's, on the uniform mesh of
--segments LGR segments of --points points (breaks as fractions of the anomaly span):
state rows X (K n + 1, 6) in the solver's scaled Tschauner-Hempel units, controls U (K n, 3),
defects D_k X_k = h_k (A_i X_i + B_i U_i) per segment (A_i, B_i the model's matrices at the
collocation anomalies, from jaxlpm), X_0 = x0, X_end = xf, |U_i| <= u_max, cost the delta-v
sum_i c_i |U_i| / u_max (c: jaxlpm's weights). Ours: `jaxlpm.solve(problem, mesh)` over the
batch in one jitted `lax.map` (`jaxlpm.batch.sweep.map_in_groups`, --width members vmapped
together, default 1; the states eliminated, the energy-to-fuel homotopy on the
six-dimensional dual to eps = 1e-6). Not vmapped over the whole batch: a vmapped while loop
runs every member until the slowest stops, and one member of 64 that needs 100 homotopy steps
(the others 8-25) made the vmapped call 45 s against 5.1 s for `lax.map` one at a time and
9.3 s in groups of 8 (measured 2026-12-05, 64 members). Peer: the same NLP written in CasADi
with the states kept and the delta-v in its epigraph form: a throttle variable sigma_i per
point, minimise sum_i c_i sigma_i subject to the defects, the ends and the cone |U_i|^2 /
u_max^2 + delta^2 <= sigma_i^2, delta <= sigma_i <= sqrt(1 + delta^2) (so |U_i| <= u_max; at
the optimum sigma_i = sqrt(|U_i|^2 / u_max^2 + delta^2), the throttle smoothed at delta = 1e-4
u_max, as `jaxlpm.solvers.fuel_constrained` smooths it). IPOPT (MUMPS, exact Hessian, tol
1e-9) from the straight line between the ends, zero control and sigma = 1/2; the solver is
built once per process and each problem's matrices and ends enter as parameters. IPOPT runs in
as many processes as this machine has cores (ours uses them through XLA).

Forms that did not converge (measured 2026-12-05, --members 4 to 16): the cone without delta
(6 of 8 at the 500-iteration limit: the cone's gradient vanishes at U = sigma = 0, so LICQ fails
at every coast point); the cone with delta = 1e-5 (3 of 4 at the limit) or 1e-6 (4 of 4); the
smoothed cost sum c_i l_eps(w_i), w_i = sqrt(|U_i|^2 / u_max^2 + delta^2), with the bound
|U_i|^2 <= u_max^2, continued over eps = 1, 0.3, ..., 3e-3 and warm-started (every member at
the limit at eps = 0.3: the objective bounced between 0.66 and 18, Newton's model of the
smoothed norm overshooting far from its minimum).

Reported: our compile (first call) and steady-state time of the batched call (median), IPOPT's
build and total solve time over the batch (the processes' wall time), the ratio of the
throughputs, the statuses, and the delta-v of both (IPOPT's is that of its control, sum_i c_i
|U_i| / u_max, which exceeds the mesh's fuel optimum F by at most delta C, C = u_max T: its
cost is at most F + delta C and at least its delta-v; ours is that optimum to ~1e-6).

    PYTHONPATH=. python experiments/benchmarks/bench_fuel.py [--members 256] [--segments 24]
        [--points 8] [--out results/bench_fuel.json]
"""

import argparse
import json
import os
import pathlib
import sys
import time

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(__file__))
from common import (batched_solves, dispersion_arguments, eccentric_ends,  # noqa: E402
                    machine_info, member, peer_pool)

import jaxlpm as lpm  # noqa: E402
from jaxlpm.nlp.transcription import collocation_s  # noqa: E402
from jaxlpm.problems.fuel_optimal import delta_v_unit, transcribe  # noqa: E402

DELTA = 1e-4                              # the peer's smoothing of the throttle
# warm_start_init_point: as measured in BENCHMARKS.md (each solve starts from the same guess,
# no multipliers passed)
IPOPT_OPTIONS = {"ipopt.tol": 1e-9, "ipopt.print_level": 0, "ipopt.sb": "yes",
                 "ipopt.hessian_approximation": "exact", "ipopt.linear_solver": "mumps",
                 "ipopt.max_iter": 500, "ipopt.warm_start_init_point": "yes", "print_time": False}


def dispersion(key, size):
    """B eccentric fuel-optimal transfers (module docstring), one batched problem."""
    k = jax.random.split(key, 4)
    orbit, xf = eccentric_ends(k[0], k[1], size)
    revolutions = jax.random.uniform(k[2], (size,), minval=0.9, maxval=1.3)
    full = jnp.ones(size)
    return lpm.FuelOptimalTransfer(orbit, jnp.zeros((size, 6)), xf, revolutions * orbit.period,
                                   0.3 * full, 50.0 * full, 1000.0 * full,
                                   j2=lpm.constants.J2_EARTH * full,
                                   r_eq=lpm.constants.R_EARTH * full)


@jax.jit
def nlp_data(problem, mesh):
    """The transcription's numbers for the peer: A_i, B_i at the collocation anomalies, the
    segments' half lengths, the scaled ends, the cost weights c_i / u_max, u_max (solver
    units)."""
    tr = transcribe(problem, mesh)
    ocp = tr.ocp
    s = collocation_s(ocp, tr.grid)

    def f(si, x, u, d):
        return ocp.dynamics(si, x, u, d, ocp.params)

    zero_x, zero_u = jnp.zeros(6), jnp.zeros(3)
    A, B = jax.vmap(lambda si, d: jax.jacfwd(f, argnums=(1, 2))(si, zero_x, zero_u, d))(
        s, ocp.node_data)
    nlp = tr.linearised(jnp.zeros((mesh.n_points, 6)))
    return dict(A=A, B=B, h=nlp.mesh_s.half_lengths, x0=nlp.x0, xf=nlp.xf,
                w=nlp.c / nlp.umax, umax=nlp.umax)


def build_ipopt(D, K, n):
    """The peer's NLP (module docstring) with the problem's numbers as parameters: (solver,
    constraint bounds lbg, ubg, variable bounds lbx, ubx)."""
    import casadi as ca

    m = K * n
    X = ca.SX.sym("X", m + 1, 6)
    U = ca.SX.sym("U", m, 3)
    sigma = ca.SX.sym("sigma", m)
    A = ca.SX.sym("A", m, 36)
    B = ca.SX.sym("B", m, 18)
    h = ca.SX.sym("h", K)
    x0, xf = ca.SX.sym("x0", 6), ca.SX.sym("xf", 6)
    w, umax = ca.SX.sym("w", m), ca.SX.sym("umax")
    g = []
    for k in range(K):
        rows = X[k * n:k * n + n + 1, :]
        DX = ca.mtimes(ca.DM(D), rows)
        for i in range(n):
            p = k * n + i
            Ai = ca.reshape(A[p, :], 6, 6).T
            Bi = ca.reshape(B[p, :], 3, 6).T
            rhs = ca.mtimes(Ai, X[p, :].T) + ca.mtimes(Bi, U[p, :].T)
            g.append(DX[i, :].T - h[k] * rhs)
    g.append(X[0, :].T - x0)
    g.append(X[m, :].T - xf)
    n_eq = 6 * m + 12
    cone = [ca.dot(U[p, :], U[p, :]) / umax**2 + DELTA**2 - sigma[p]**2 for p in range(m)]
    z = ca.vertcat(ca.vec(X), ca.vec(U), sigma)
    params = ca.vertcat(ca.vec(A), ca.vec(B), h, x0, xf, w, umax)
    nlp = {"x": z, "p": params, "f": umax * ca.dot(w, sigma), "g": ca.vertcat(*g, *cone)}
    solver = ca.nlpsol("fuel", "ipopt", nlp, IPOPT_OPTIONS)
    lbg = np.concatenate([np.zeros(n_eq), np.full(m, -np.inf)])
    ubg = np.zeros(n_eq + m)
    lbx = np.concatenate([np.full(z.shape[0] - m, -np.inf), np.full(m, DELTA)])
    ubx = np.concatenate([np.full(z.shape[0] - m, np.inf), np.full(m, np.sqrt(1.0 + DELTA**2))])
    return solver, lbg, ubg, lbx, ubx


def _peer_worker(args):
    """Solve a share of the problems with one IPOPT solver built in this process."""
    D, K, n, data = args
    t0 = time.perf_counter()
    solver, lbg, ubg, lbx, ubx = build_ipopt(D, K, n)
    build = time.perf_counter() - t0
    m = K * n
    out = []
    for d in data:
        A = d["A"].reshape(m, 36)
        B = d["B"].reshape(m, 18)
        params = np.concatenate([A.T.reshape(-1), B.T.reshape(-1), d["h"], d["x0"], d["xf"],
                                 d["w"], [d["umax"]]])
        frac = np.linspace(0.0, 1.0, m + 1)[:, None]
        X0 = (1 - frac) * d["x0"][None] + frac * d["xf"][None]
        z0 = np.concatenate([X0.T.reshape(-1), np.zeros(3 * m), np.full(m, 0.5)])
        t0 = time.perf_counter()
        res = solver(x0=z0, p=params, lbg=lbg, ubg=ubg, lbx=lbx, ubx=ubx)
        dt = time.perf_counter() - t0
        stats = solver.stats()
        z = np.asarray(res["x"]).ravel()
        Us = z[6 * (m + 1):6 * (m + 1) + 3 * m].reshape(3, m).T      # ca.vec is column-major
        out.append(dict(cost=float(np.sum(d["w"] * np.linalg.norm(Us, axis=1))), seconds=dt,
                        status=stats["return_status"], iterations=stats["iter_count"]))
    return build, out


def main():
    ap = argparse.ArgumentParser()
    dispersion_arguments(ap, "results/bench_fuel.json")
    args = ap.parse_args()
    import casadi as ca

    problems = dispersion(jax.random.PRNGKey(args.seed), args.members)
    mesh = lpm.segmented_lgr(lpm.uniform_breaks(0.0, 1.0, args.segments), args.points)
    sols, first, steady, counts = batched_solves(problems, mesh, args.width)
    status = np.asarray(sols.status)
    ours_dv = np.asarray(sols.cost)
    print(f"ours: {args.members} members, first call {first:.1f} s (compiles), steady "
          f"{steady['median_s']:.3f} s per batch; statuses {counts}", flush=True)

    data = []
    for i in range(args.members):
        d = nlp_data(member(problems, i), mesh)
        data.append({k: np.asarray(v) for k, v in d.items()})
    D = np.asarray(mesh.grid.D)
    procs = len(os.sched_getaffinity(0))
    shares = [(D, args.segments, args.points, data[j::procs]) for j in range(procs)]
    builds, peer, peer_wall, peer_status = peer_pool(_peer_worker, shares, args.members)
    solve_total = sum(r["seconds"] for r in peer)
    # IPOPT's delta-v in the scaled units sum c_i |U_i| / u_max; ours in m/s
    unit = np.asarray(jax.vmap(delta_v_unit)(problems))
    ipopt_dv = np.array([r["cost"] for r in peer]) * unit
    both = (status == lpm.Status.SUCCESS) | (status == lpm.Status.INACCURATE)
    ok_peer = np.array([r["status"] == "Solve_Succeeded" for r in peer])
    sel = both & ok_peer
    # IPOPT's smoothed optimum costs more than the mesh's fuel optimum, by at most delta C
    if not sel.any():
        print(f"no member converged with both solvers (IPOPT: {peer_status}): no ratio",
              flush=True)
        return
    rel = (ipopt_dv[sel] - ours_dv[sel]) / ours_dv[sel]
    C = np.asarray(problems.max_acceleration * problems.duration)[sel]
    within = int(np.sum((ipopt_dv[sel] - ours_dv[sel] >= -1e-6 * ours_dv[sel])
                        & (ipopt_dv[sel] - ours_dv[sel] <= DELTA * C)))
    ratio = (solve_total / procs) / steady["median_s"]
    print(f"IPOPT: {procs} processes, build {max(builds):.1f} s, {peer_wall:.1f} s wall for "
          f"the batch ({solve_total:.1f} s of solves, median "
          f"{np.median([r['seconds'] for r in peer]):.3f} s, iterations median "
          f"{np.median([r['iterations'] for r in peer]):.0f}); statuses {peer_status}",
          flush=True)
    print(f"throughput ratio ours / IPOPT ({procs} processes): {ratio:.1f}; delta-v relative "
          f"excess of IPOPT's over ours on {int(sel.sum())} members both converged: median "
          f"{np.median(rel):.1e}, min {np.min(rel):.1e}, max {np.max(rel):.1e} relative; "
          f"within the smoothing's bound: {within}", flush=True)
    out = pathlib.Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(dict(
        args=vars(args), machine=machine_info(casadi=ca.__version__),
        ipopt_options=IPOPT_OPTIONS,
        ours=dict(first_call_s=first, steady=steady, statuses=counts),
        ipopt=dict(processes=procs, build_s=builds, wall_s=peer_wall, solve_total_s=solve_total,
                   statuses=peer_status),
        throughput_ratio=ratio,
        dv_excess_of_ipopt=dict(members=int(sel.sum()), median=float(np.median(rel)),
                                min=float(np.min(rel)), max=float(np.max(rel)),
                                within_bound=within)), indent=1, default=str))


if __name__ == "__main__":
    main()
