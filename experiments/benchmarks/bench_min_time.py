"""Benchmark of the batched minimum-time solve on eccentric chiefs against CasADi + IPOPT one
problem at a time on the same transcription.

The problems: a dispersion of B `MinimumTimeTransfer`s on the linear (Tschauner-Hempel) model,
chief perigee radius 7000 km and e uniform in [0, 0.5], from rest at the chief to a point at
rest uniform in a box of +-4 km (radial, along-track) and +-1 km (normal), at a constant
thrust of 0.1 N on 50 kg (a = 2 mm/s^2: minimum times of about 0.1-1.2 chief periods),
t_max = 5 chief periods.

The transcription (both solvers): method "condensed"'s, on the uniform mesh of --segments LGR
segments of --points points whose breaks are fractions of the anomaly span [f0, f_f(T)]:
scaled Tschauner-Hempel state rows X (K n + 1, 6) (x~ / L, L = max(|r0|, |rf|, 1 m)),
controls U (K n, 3) in the unit L k^4 (k^2 = sqrt(mu / p^3), the same at every anomaly),
collocation anomalies s_i = f0 + tau_i (f_f(T) - f0) (tau_i the points' fractions), defects
D_k X_k = h_k(T) (A(s_i) X_i + B(s_i) U_i) per segment, h_k(T) = (f_f(T) - f0) (b_{k+1} - b_k)
/ 2, A the Tschauner-Hempel matrix (x~'' = 3 x~ / rho + 2 y~', y~'' = -2 x~', z~'' = -z~,
rho = 1 + e cos s), B = [0; I / rho^3]; X_0 = x0, X_end = xf mapped at f_f(T) (x~ = rho r / L,
x~' = (-e sin f r + v / (k^2 rho)) / L), the engine at full thrust |U_i| = u_max (u_max =
(T/m) / (L k^4)), minimise T. Ours: `jaxlpm.solve(problem, mesh)` over the batch in one
jitted `lax.map` (`jaxlpm.batch.sweep.map_in_groups`, --width members vmapped together,
default 1: a vmapped while loop runs every member until the slowest stops, as bench_fuel.py
measured; method "condensed": the states eliminated, Newton on the reachable set's support
F*(T) = 1).
Peer: the same NLP written in CasADi with the states kept and T free (as r = T / period, the
objective): f_f(T) from Kepler's equation in the NLP (M = M0 + 2 pi r, 8 Newton steps on the
continuous eccentric anomaly from E = M + e sin M, then f = E + 2 atan(b sin E / (1 - b cos E)),
b = e / (1 + sqrt(1 - e^2))), the thrust as |U_i|^2 / u_max^2 <= 1 (--thrust-equality: = 1;
the same minimum time, see `_peer_worker`). Before the solves its constraint function is
checked against jaxlpm's own transcription (anomalies, A_i, B_i, h_k, ends) at random points
for a few members. IPOPT (MUMPS, exact Hessian, tol 1e-9) from jaxlpm's starting duration
T0 = 2 sqrt(|dr| / a) + |dv| / a (the rest-to-rest bang-bang time), the straight line from x0
to the mapped xf at f_f(T0), and the bang-bang control +-u_max along the scaled position
change (switching at half the span); the solver is built once per process and each problem's
numbers enter as parameters. IPOPT runs in as many processes as this machine has cores (ours
uses them through XLA).

Reported: our compile (first call) and steady-state time of the batched call (median), the
statuses, IPOPT's build and total solve time over the batch (and the processes' wall time),
its median solve, iterations and statuses, the ratio of the throughputs ((IPOPT's solve
seconds / processes) / our batch seconds), and the relative difference (IPOPT's - ours) / ours
of T* on the members both converged: with the thrust inequality IPOPT's interior point ends
with |U_i| just inside u_max, so its T* is above ours by ~1e-7 (3e-8 to 9e-8 at --members 8);
with --thrust-equality they agree to ~1e-15 (--members 4). Measured 2026-12-05 with
--members 8 (2 cores, loaded): one member in eight (T* = 1.13 periods, T0 = 0.35) has no
feasible duration between T0 and ~1.1 periods (the constant-thrust reachable sets are not
nested in T), and IPOPT from T0 does not get past them (the inequality reports a local
infeasibility in ~1 s, the equality reaches its iteration limit).

    PYTHONPATH=. python experiments/benchmarks/bench_min_time.py [--members 256]
        [--segments 24] [--points 8] [--thrust-equality] [--out results/bench_min_time.json]
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
from jaxlpm.orbits.kepler import mean_from_true  # noqa: E402
from jaxlpm.problems.energy_optimal import control_scale, model_state  # noqa: E402
from jaxlpm.problems.fuel_optimal import transcribe  # noqa: E402
from jaxlpm.problems.scaling import length_scale  # noqa: E402

THRUST, MASS = 0.1, 50.0           # N, kg (module docstring)
T_MAX_PERIODS = 5.0
KEPLER_NEWTON = 8                  # the peer's Newton steps on Kepler's equation
CHECKED = 3                        # members whose peer transcription is checked against ours
IPOPT_OPTIONS = {"ipopt.tol": 1e-9, "ipopt.print_level": 0, "ipopt.sb": "yes",
                 "ipopt.hessian_approximation": "exact", "ipopt.linear_solver": "mumps",
                 "ipopt.max_iter": 500, "print_time": False}


def dispersion(key, size):
    """B eccentric minimum-time transfers (module docstring), one batched problem."""
    k = jax.random.split(key, 2)
    orbit, xf = eccentric_ends(k[0], k[1], size)
    full = jnp.ones(size)
    bounds = jnp.stack([0.0 * full, T_MAX_PERIODS * orbit.period], axis=1)
    return lpm.MinimumTimeTransfer(orbit, jnp.zeros((size, 6)), xf, THRUST * full,
                                   MASS * full, duration_bounds=bounds,
                                   j2=lpm.constants.J2_EARTH * full,
                                   r_eq=lpm.constants.R_EARTH * full)


def _fuel_twin(problem, duration):
    """The fixed-duration transfer whose transcription method "condensed" shares."""
    return lpm.FuelOptimalTransfer(problem.orbit, problem.x0, problem.xf, duration,
                                   problem.thrust, problem.mass, 1.0)


@jax.jit
def peer_parameters(problem):
    """The peer's parameter vector [e, k^2, f0, M0, u_max, x0 (scaled TH), xf / L] and its
    start r0 = T0 / period and bound r_max = t_max / period."""
    o = problem.orbit
    energy = _fuel_twin(problem, 1.0).energy_problem()
    d = problem.xf - problem.x0
    a = problem.acceleration
    T0 = 2.0 * jnp.sqrt(jnp.linalg.norm(d[:3]) / a) + jnp.linalg.norm(d[3:]) / a
    params = jnp.concatenate([
        jnp.stack([o.e, o.k2, o.f0, mean_from_true(o.f0, o.e), a / control_scale(energy)]),
        model_state(energy, problem.x0, o.f0), problem.xf / length_scale(problem)])
    return params, T0 / o.period, problem.bounds[1] / o.period


def peer_nlp(D, fractions, breaks):
    """The peer's NLP (module docstring) in CasADi: (variables z = [vec X, vec U, r],
    parameters, constraints g, the end state X_end(r, params)); the first 6 m + 12 constraints
    are the defects and ends, the last m the thrust."""
    import casadi as ca

    K, n = len(breaks) - 1, D.shape[0]
    m = K * n
    X = ca.SX.sym("X", m + 1, 6)
    U = ca.SX.sym("U", m, 3)
    r = ca.SX.sym("r")
    p = ca.SX.sym("p", 17)
    e, k2, f0, M0, umax = p[0], p[1], p[2], p[3], p[4]
    x0, xf = p[5:11], p[11:17]
    M = M0 + 2 * np.pi * r
    E = M + e * ca.sin(M)
    for _ in range(KEPLER_NEWTON):
        E = E - (E - e * ca.sin(E) - M) / (1 - e * ca.cos(E))
    b = e / (1 + ca.sqrt(1 - e**2))
    ff = E + 2 * ca.atan2(b * ca.sin(E), 1 - b * ca.cos(E))
    span = ff - f0
    g = []
    for k in range(K):
        DX = ca.mtimes(ca.DM(D), X[k * n:k * n + n + 1, :])
        h = span * (breaks[k + 1] - breaks[k]) / 2
        for i in range(n):
            j = k * n + i
            x, u = X[j, :], U[j, :]
            rho = 1 + e * ca.cos(f0 + fractions[j] * span)
            rhs = ca.horzcat(x[3], x[4], x[5], 3 * x[0] / rho + 2 * x[4] + u[0] / rho**3,
                             -2 * x[3] + u[1] / rho**3, -x[2] + u[2] / rho**3)
            g.append((DX[i, :] - h * rhs).T)
    rho_f = 1 + e * ca.cos(ff)
    x_end = ca.vertcat(rho_f * xf[:3], -e * ca.sin(ff) * xf[:3] + xf[3:] / (k2 * rho_f))
    g.append(X[0, :].T - x0)
    g.append(X[m, :].T - x_end)
    g.extend(ca.dot(U[j, :], U[j, :]) / umax**2 - 1 for j in range(m))
    return ca.vertcat(ca.vec(X), ca.vec(U), r), p, ca.vertcat(*g), x_end


def _mesh_numbers(mesh):
    return (np.asarray(mesh.grid.D), np.asarray(mesh.points).reshape(-1),
            np.asarray(mesh.breaks))


def check_peer(problems, mesh, members, seed=1):
    """Largest relative difference between the peer's constraints and those built from
    jaxlpm's transcription (`transcribe`: its anomalies, A_i = df/dx, B_i = df/du of
    `ocp.dynamics`, h_k, scaled ends, u_max) at random X, U and a random duration, over
    `members` members."""
    import casadi as ca

    D, fractions, breaks = _mesh_numbers(mesh)
    z, p, g, _ = peer_nlp(D, fractions, breaks)
    g_fun = ca.Function("g", [z, p], [g])
    K, n = mesh.n_segments, mesh.grid.n
    m = K * n
    rng = np.random.default_rng(seed)
    worst = 0.0
    for i in range(members):
        problem = member(problems, i)
        params, _, _ = peer_parameters(problem)
        r = rng.uniform(0.2, 2.0)
        tr = transcribe(_fuel_twin(problem, r * problem.orbit.period), mesh)
        ocp = tr.ocp
        s = collocation_s(ocp, tr.grid)
        A, B = jax.vmap(lambda si: jax.jacfwd(
            lambda x, u: ocp.dynamics(si, x, u, None, ocp.params), argnums=(0, 1))(
                jnp.zeros(6), jnp.zeros(3)))(s)
        A, B = np.asarray(A), np.asarray(B)
        h = 0.5 * (float(ocp.sf) - float(ocp.s0)) * np.diff(breaks)
        umax = float(tr.linearised(jnp.zeros((m, 6))).umax)
        X, U = rng.normal(size=(m + 1, 6)), rng.normal(size=(m, 3))
        ref = []
        for k in range(K):
            DX = D @ X[k * n:k * n + n + 1]
            rows = slice(k * n, k * n + n)
            ref.append(DX - h[k] * (np.einsum("iab,ib->ia", A[rows], X[rows])
                                    + np.einsum("iab,ib->ia", B[rows], U[rows])))
        ref = np.concatenate([np.concatenate(ref).reshape(-1), X[0] - ocp.params["x0"],
                              X[m] - ocp.params["xf"], np.sum(U**2, axis=1) / umax**2 - 1])
        zv = np.concatenate([X.T.reshape(-1), U.T.reshape(-1), [r]])  # ca.vec: column-major
        ours = np.asarray(g_fun(zv, np.asarray(params))).ravel()
        worst = max(worst, float(np.max(np.abs(ours - ref)) / np.max(np.abs(ref))))
    return worst


def _peer_worker(args):
    """Solve a share of the problems with one IPOPT solver built in this process.

    The thrust is |U_i| <= u_max unless `equality`: the minimum-time engine fires at full
    thrust either way (and method "condensed" tests reachability with |v_i| <= 1 too), but
    where IPOPT does not converge the equality costs it 0.3-0.5 s per iteration in inertia
    corrections (regularisation up to 1e19) to its iteration limit, the inequality about
    1 s in all before it reports a local infeasibility (measured 2026-12-05)."""
    import casadi as ca

    D, fractions, breaks, equality, data = args
    t0 = time.perf_counter()
    z, p, g, x_end = peer_nlp(D, fractions, breaks)
    solver = ca.nlpsol("min_time", "ipopt", {"x": z, "p": p, "f": z[-1], "g": g},
                       IPOPT_OPTIONS)
    end = ca.Function("end", [z[-1], p], [x_end])
    build = time.perf_counter() - t0
    m = fractions.size
    ubg = np.zeros(g.shape[0])
    lbg = np.concatenate([np.zeros(g.shape[0] - m), np.full(m, 0.0 if equality else -np.inf)])
    out = []
    for params, r0, r_max in data:
        x0, umax = params[5:11], params[4]
        xf = np.asarray(end(r0, params)).ravel()
        rows = np.concatenate([fractions, [1.0]])[:, None]
        X0 = (1 - rows) * x0 + rows * xf
        dr = xf[:3] - x0[:3]
        U0 = umax * np.where(fractions[:, None] < 0.5, 1.0, -1.0) * dr / np.linalg.norm(dr)
        lbx = np.concatenate([np.full(z.shape[0] - 1, -np.inf), [0.0]])
        ubx = np.concatenate([np.full(z.shape[0] - 1, np.inf), [r_max]])
        t0 = time.perf_counter()
        res = solver(x0=np.concatenate([X0.T.reshape(-1), U0.T.reshape(-1), [r0]]), p=params,
                     lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
        dt = time.perf_counter() - t0
        stats = solver.stats()
        out.append(dict(r=float(res["x"][-1]), seconds=dt, status=stats["return_status"],
                        iterations=stats["iter_count"]))
    return build, out


def main():
    ap = argparse.ArgumentParser()
    dispersion_arguments(ap, "results/bench_min_time.json")
    ap.add_argument("--thrust-equality", action="store_true",
                    help="the peer's thrust as |U| = u_max (default |U| <= u_max)")
    args = ap.parse_args()
    import casadi as ca

    problems = dispersion(jax.random.PRNGKey(args.seed), args.members)
    mesh = lpm.segmented_lgr(lpm.uniform_breaks(0.0, 1.0, args.segments), args.points)
    sols, first, steady, counts = batched_solves(problems, mesh, args.width)
    status = np.asarray(sols.status)
    period = np.asarray(problems.orbit.period)
    ours_T = np.asarray(sols.duration) / period
    print(f"ours: {args.members} members, first call {first:.1f} s (compiles), steady "
          f"{steady['median_s']:.3f} s per batch; statuses {counts}; T* {ours_T.min():.2f}-"
          f"{ours_T.max():.2f} chief periods", flush=True)

    checked = min(CHECKED, args.members)
    mismatch = check_peer(problems, mesh, checked)
    print(f"peer's constraints against jaxlpm's transcription ({checked} members, random "
          f"points): largest relative difference {mismatch:.1e}", flush=True)

    data = []
    for i in range(args.members):
        params, r0, r_max = peer_parameters(member(problems, i))
        data.append((np.asarray(params), float(r0), float(r_max)))
    procs = len(os.sched_getaffinity(0))
    shares = [(*_mesh_numbers(mesh), args.thrust_equality, data[j::procs])
              for j in range(procs)]
    builds, peer, peer_wall, peer_status = peer_pool(_peer_worker, shares, args.members)
    solve_total = sum(r["seconds"] for r in peer)
    ratio = (solve_total / procs) / steady["median_s"]
    print(f"IPOPT: {procs} processes, build {max(builds):.1f} s, {peer_wall:.1f} s wall for "
          f"the batch ({solve_total:.1f} s of solves, median "
          f"{np.median([r['seconds'] for r in peer]):.3f} s, iterations median "
          f"{np.median([r['iterations'] for r in peer]):.0f}, max "
          f"{max(r['iterations'] for r in peer)}); statuses {peer_status}", flush=True)
    print(f"throughput ratio ours / IPOPT ({procs} processes): {ratio:.1f}", flush=True)

    ipopt_T = np.array([r["r"] for r in peer])
    sel = (((status == lpm.Status.SUCCESS) | (status == lpm.Status.INACCURATE))
           & np.array([r["status"] == "Solve_Succeeded" for r in peer]))
    agreement = None
    if sel.any():
        rel = (ipopt_T[sel] - ours_T[sel]) / ours_T[sel]
        agreement = dict(members=int(sel.sum()), median=float(np.median(rel)),
                         min=float(np.min(rel)), max=float(np.max(rel)))
        print(f"T* relative difference (IPOPT - ours) / ours on {int(sel.sum())} members both "
              f"converged: median {agreement['median']:.1e}, min {agreement['min']:.1e}, max "
              f"{agreement['max']:.1e}", flush=True)
    else:
        print("no member converged with both solvers", flush=True)
    out = pathlib.Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(dict(
        args=vars(args), machine=machine_info(casadi=ca.__version__),
        ipopt_options=IPOPT_OPTIONS, peer_check_relative_difference=mismatch,
        ours=dict(first_call_s=first, steady=steady, statuses=counts,
                  status_by_member=[lpm.Status(int(s)).name for s in status],
                  duration_periods=ours_T.tolist()),
        ipopt=dict(processes=procs, build_s=builds, wall_s=peer_wall, solve_total_s=solve_total,
                   solve_median_s=float(np.median([r["seconds"] for r in peer])),
                   iterations=[r["iterations"] for r in peer], statuses=peer_status,
                   status_by_member=[r["status"] for r in peer],
                   duration_periods=ipopt_T.tolist()),
        throughput_ratio=ratio, duration_relative_difference=agreement), indent=1,
        default=str))


if __name__ == "__main__":
    main()
