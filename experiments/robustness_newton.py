"""Robustness of the Newton-KKT transfer solver over randomly dispersed mei2010-like problems.

Issue 3's acceptance item: from the linear law's warm start, at least 99.9 % of 1000 randomly
dispersed problems converge, and every other one reports a status (never a NaN without one).

Problems: `jaxlpm.cases.mei2010.dispersion` (chief perigee altitude 600 km, e ~ U[0, 0.7],
1-5 revolutions, f0 and argp uniform, i = raan = 30 deg; chaser LVLH position uniform in a 50 km
cube, velocity within +-10 m/s per axis; rendezvous at the origin at rest). Grid: lgl(65)
(mei2010's N = 64; --points to change). Solver: `jaxlpm.solve(problem, grid, method="newton",
options=NewtonOptions(...))` with the default options (--max-iterations to change the limit),
which warm-starts from the linear model's KKT solution.

The problems are solved in chunks of --chunk by ONE compiled function: jax.jit(jax.vmap(solve))
by default, or, with --vmap-width w < --chunk, jax.lax.map over vmapped groups of w inside the
jit. A vmapped while-loop runs every member until the slowest one stops, so on CPU a chunk of
50 with one 40-iteration failure costs 50 x 40 iterations; --vmap-width 1 (one problem at a
time inside the compiled call) wastes nothing there, a GPU wants wide groups. The last chunk is
padded with copies of its first problem so that no second compile happens. Each finished chunk
is written to OUT/chunks/chunk_XXXXX.npz (atomically): a restarted run (after a crash or
Ctrl-C) skips the chunks already there. OUT/meta.json pins the run's settings (and records the
git commit); a restart with other settings is refused.

Per problem: the sampled parameters, status, iterations, cost (m^2/s^3), constraint and
stationarity residuals (solver units), the KKT-residual history, whether any output is NaN or
Inf, the largest excursion along the transfer and the nodal controls. At the end: the summary
(counts per Status, fraction converged, iterations, NaN-without-status count, timing with the
compile separate, the non-converged problems with their parameters, failure rates binned by e,
revolutions, |v0| and the warm start's KKT residual), printed and written to OUT/summary.json;
and a truth check: --verify converged problems (random, fixed seed; all of them if --verify
>= n) flown through `jaxlpm.verify.propagate_nonlinear` (two-body, plus J2 for model "j2";
Dopri8, rtol = atol = 1e-12) with the barycentric interpolant of the stored nodal control in
the chief's anomaly (`jaxlpm.solution.control_interpolant`, what the solution's
`trajectory.flight_control()` gives): terminal miss (m, m/s) against the target, overall and
binned by revolutions and e.

Run from the repository root; on 2 CPU cores about 8 min for 1000 problems on lgl(65) with
--vmap-width 1 (several times that in lockstep: a chunk with one failure runs 40 iterations
for all its members), 2 min for 200 with "j2", 35 min for 1000 on lgl(129):
    python experiments/robustness_newton.py --n 1000 --seed 0 --vmap-width 1 --model two-body
    python experiments/robustness_newton.py --n 200 --seed 0 --vmap-width 1 --model j2
Results go to results/robustness_newton_<model>_n<n>_s<seed>[...]/ unless --out is given.
"""

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

# jaxlpm first: it sets XLA's CPU flags before JAX starts its backend
from jaxlpm import NewtonOptions, lgl, solve
import jax  # noqa: E402

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402

from jaxlpm.batch import map_in_groups, save_npz_atomic, write_json_atomic  # noqa: E402
from jaxlpm.cases.mei2010 import dispersion, dispersion_parameters  # noqa: E402
from jaxlpm.solution import control_interpolant  # noqa: E402
from jaxlpm.status import Status  # noqa: E402
from jaxlpm.verify import propagate_nonlinear, terminal_error  # noqa: E402

SCHEMA_VERSION = 1
ROOT = Path(__file__).resolve().parent.parent
N_POINTS = 65                       # default grid lgl(65): mei2010's N = 64


def parse_args(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=1000, help="number of problems (default 1000)")
    ap.add_argument("--seed", type=int, default=0, help="jax.random seed of the dispersion")
    ap.add_argument("--chunk", type=int, default=50, help="problems per compiled call (50)")
    ap.add_argument("--vmap-width", type=int, default=None,
                    help="members solved in lockstep by vmap inside a chunk (default: the whole "
                         "chunk, i.e. jit(vmap)); smaller: lax.map over vmapped groups")
    ap.add_argument("--model", default="two-body", choices=("linear", "two-body", "j2"))
    ap.add_argument("--max-iterations", type=int, default=NewtonOptions().max_iterations,
                    help="NewtonOptions.max_iterations (default: the library's default, "
                         f"{NewtonOptions().max_iterations})")
    ap.add_argument("--points", type=int, default=N_POINTS,
                    help=f"LGL points of the grid (default {N_POINTS}: mei2010's N = 64)")
    ap.add_argument("--verify", type=int, default=20,
                    help="converged problems to fly through the nonlinear model (20)")
    ap.add_argument("--out", type=Path, default=None,
                    help="output folder (default results/robustness_newton_<model>_n<n>_s<seed>)")
    ap.add_argument("--cache", type=Path, default=ROOT / ".jax_cache",
                    help="persistent compilation cache folder (default .jax_cache)")
    args = ap.parse_args(argv)
    if args.n < 1 or args.chunk < 1:
        ap.error("--n and --chunk must be positive")
    if args.vmap_width is None or args.vmap_width > args.chunk:
        args.vmap_width = args.chunk
    args.options = NewtonOptions(max_iterations=args.max_iterations)
    if args.out is None:
        tag = "" if args.options == NewtonOptions() else f"_it{args.max_iterations}"
        tag += "" if args.points == N_POINTS else f"_lgl{args.points}"
        args.out = ROOT / "results" / f"robustness_newton_{args.model}_n{args.n}_s{args.seed}{tag}"
    return args


# ------------------------------------------------------------------------------------------
# the compiled per-chunk function


def solve_record(problem, grid, options):
    """Solve one problem; return a small record of flat arrays (no solution pytree)."""
    sol = solve(problem, grid, method="newton", options=options, throw=False)
    st = sol.stats
    floats = [x for x in jax.tree_util.tree_leaves((sol.cost, sol.trajectory, st))
              if jnp.issubdtype(x.dtype, jnp.floating)]
    any_nan = jnp.any(jnp.stack([jnp.any(jnp.isnan(x)) for x in floats]))
    any_inf = jnp.any(jnp.stack([jnp.any(jnp.isinf(x)) for x in floats]))
    return dict(
        status=sol.status, iterations=st["iterations"].astype(jnp.int32), cost=sol.cost,
        constraint_residual=st["constraint_residual"],
        stationarity_residual=st["stationarity_residual"], history=st["history"],
        any_nan=any_nan, any_inf=any_inf,
        max_position=jnp.max(jnp.linalg.norm(sol.node_states[:, :3], axis=1)),
        max_velocity=jnp.max(jnp.linalg.norm(sol.node_states[:, 3:], axis=1)),
        max_control=jnp.max(jnp.linalg.norm(sol.node_controls, axis=1)),
        node_controls=sol.node_controls, s0=sol.trajectory.s0, sf=sol.trajectory.sf)


def make_chunk_solver(grid, vmap_width, chunk, options=NewtonOptions()):
    one = lambda p: solve_record(p, grid, options)                       # noqa: E731
    if vmap_width >= chunk:
        return jax.jit(jax.vmap(one))
    return jax.jit(lambda ps: map_in_groups(one, ps, vmap_width))


def lockstep_iterations(chunk_file, args):
    """Iterations each member's vmap group ran (the group's slowest member): the cost of the
    lockstep, counted over the chunk padded with copies of its first problem."""
    it = chunk_file["iterations"]
    w = int(chunk_file["vmap_width"][0]) if "vmap_width" in chunk_file.files else args.vmap_width
    padded = np.concatenate([it, np.full(args.chunk - len(it), it[0])])
    run = np.concatenate([np.full(len(padded[i:i + w]), padded[i:i + w].max())
                          for i in range(0, args.chunk, w)])
    return run[: len(it)]


def take(tree, idx):
    return jax.tree.map(lambda x: x[idx], tree)


# ------------------------------------------------------------------------------------------
# files


def git_state():
    """The library's commit and whether jaxlpm/ differs from it (None outside a checkout)."""
    try:
        run = lambda *c: subprocess.run(["git", *c], cwd=ROOT, capture_output=True, text=True,  # noqa: E731
                                        check=True).stdout.strip()
        return dict(commit=run("rev-parse", "HEAD"),
                    jaxlpm_modified=bool(run("status", "--porcelain", "--", "jaxlpm")))
    except (OSError, subprocess.CalledProcessError):
        return None


def check_meta(out: Path, meta: dict):
    path = out / "meta.json"
    if path.exists():
        old = json.loads(path.read_text())
        keys = ("schema_version", "n", "seed", "chunk", "model", "n_points", "options")
        diff = {k: (old.get(k), meta[k]) for k in keys if old.get(k) != meta[k]}
        if diff:
            sys.exit(f"{out} holds a run with other settings {diff} (old, new): choose another "
                     f"--out or delete it")
    else:
        write_json_atomic(path, meta)


# ------------------------------------------------------------------------------------------
# summary


def status_name(code):
    try:
        return Status(int(code)).name
    except ValueError:
        return f"UNKNOWN({int(code)})"


def binned_rates(x, ok, edges):
    rows = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        m = (x >= lo) & (x < hi) if hi != edges[-1] else (x >= lo) & (x <= hi)
        rows.append(dict(range=[float(lo), float(hi)], n=int(m.sum()),
                         failed=int((m & ~ok).sum())))
    return rows


def summarise(rec, params, timing, args):
    status = rec["status"]
    ok = status == Status.SUCCESS
    valid_codes = np.isin(status, [s.value for s in Status])
    nan_any = rec["any_nan"] | rec["any_inf"]
    counts = {}
    for code in status:
        counts[status_name(code)] = counts.get(status_name(code), 0) + 1
    it = rec["iterations"]
    failures = []
    for k in np.flatnonzero(~ok):
        hist = rec["history"][k][: max(int(it[k]), 1)]     # KKT residual at each iterate
        failures.append(dict(
            index=int(k), status=status_name(status[k]), iterations=int(it[k]),
            e=params["e"][k], a_km=params["a"][k] / 1e3, revolutions=params["revolutions"][k],
            f0_deg=np.rad2deg(params["f0"][k]), argp_deg=np.rad2deg(params["argp"][k]),
            x0=params["x0"][k], cost=rec["cost"][k],
            constraint_residual=rec["constraint_residual"][k],
            stationarity_residual=rec["stationarity_residual"][k],
            initial_kkt=rec["history"][k][0],
            max_position_km=rec["max_position"][k] / 1e3, any_nan=bool(nan_any[k]),
            kkt_history=hist))
    steady = np.asarray(timing["chunk_seconds"])
    n_chunks = len(steady)
    lockstep = rec["iterations_run"]
    return dict(
        schema_version=SCHEMA_VERSION, model=args.model, n=int(len(status)), seed=args.seed,
        grid=f"lgl({args.points})", options=str(args.options),
        status_counts=counts, converged=int(ok.sum()), fraction_converged=float(ok.mean()),
        target_fraction=0.999, meets_target=bool(ok.mean() >= 0.999),
        nan_without_status=int((nan_any & ok).sum() + (~valid_codes).sum()),
        nan_or_inf_outputs=int(nan_any.sum()), unknown_status_codes=int((~valid_codes).sum()),
        iterations=dict(max=int(it.max()), max_converged=int(it[ok].max()) if ok.any() else None,
                        mean_converged=float(it[ok].mean()) if ok.any() else None,
                        percentiles_converged={p: float(np.percentile(it[ok], p))
                                               for p in (50, 90, 99)} if ok.any() else None,
                        histogram={int(v): int((it == v).sum()) for v in np.unique(it)}),
        cost_m2_s3=dict(min=float(rec["cost"][ok].min()), median=float(np.median(rec["cost"][ok])),
                        max=float(rec["cost"][ok].max())) if ok.any() else None,
        residuals_converged=dict(
            constraint_max=float(rec["constraint_residual"][ok].max()),
            stationarity_max=float(rec["stationarity_residual"][ok].max())) if ok.any() else None,
        max_excursion_km=dict(median=float(np.median(rec["max_position"]) / 1e3),
                              max=float(rec["max_position"].max() / 1e3)),
        timing=dict(
            compile_seconds=timing["compile_seconds"], chunks=n_chunks, chunk_size=args.chunk,
            vmap_width=args.vmap_width,
            steady_seconds_total=float(steady.sum()),
            steady_seconds_per_chunk=dict(min=float(steady.min()), median=float(np.median(steady)),
                                          max=float(steady.max())) if n_chunks else None,
            steady_seconds_per_problem=float(steady.sum() / len(status)),
            lockstep_efficiency=float(it.sum() / max(lockstep.sum(), 1))),
        failure_rate_by_e=binned_rates(params["e"], ok, np.linspace(0.0, 0.7, 8)),
        failure_rate_by_revolutions=binned_rates(params["revolutions"], ok,
                                                 np.linspace(1.0, 5.0, 5)),
        failure_rate_by_speed_m_s=binned_rates(np.linalg.norm(params["x0"][:, 3:], axis=1), ok,
                                               np.array([0.0, 5.0, 10.0, 15.0, 17.33])),
        failure_rate_by_log10_initial_kkt=binned_rates(
            np.log10(np.maximum(rec["history"][:, 0], 1e-300)), ok,
            np.array([-300.0, 0.0, 1.0, 2.0, 3.0, 4.0, 300.0])),
        failures=failures)


# ------------------------------------------------------------------------------------------
# truth check


def verify(problems, rec, params, args, grid, out):
    ok = np.flatnonzero(rec["status"] == Status.SUCCESS)
    k = min(args.verify, len(ok))
    if k == 0:
        return None
    path = out / f"verify_{k}.npz"
    if path.exists():
        v = dict(np.load(path))
    else:
        rng = np.random.default_rng(args.seed)
        idx = np.sort(rng.choice(ok, size=k, replace=False))
        sub = take(problems, jnp.asarray(idx))

        j2_on = args.model == "j2"

        def fly(p, u, s0, sf):
            # the stored nodal control as the solution's flight control (in the anomaly)
            control = control_interpolant(grid, u, s0, sf, variable="anomaly")
            j2 = p.j2 if j2_on else 0.0 * p.j2
            _, states, status = propagate_nonlinear(p.orbit, p.x0, p.duration, control,
                                                    n_save=2, j2=j2, r_eq=p.r_eq)
            return terminal_error(states, p.xf), status == Status.SUCCESS

        t = time.time()
        miss, good = jax.jit(jax.vmap(fly))(
            sub, jnp.asarray(rec["node_controls"][idx]), jnp.asarray(rec["s0"][idx]),
            jnp.asarray(rec["sf"][idx]))
        miss = np.asarray(miss)
        v = dict(index=idx, position_miss_m=miss[:, 0], velocity_miss_m_s=miss[:, 1],
                 integrator_ok=np.asarray(good), seconds=np.array(time.time() - t))
        save_npz_atomic(path, **v)

    def dist(x):
        return dict(min=float(x.min()), median=float(np.median(x)),
                    p90=float(np.percentile(x, 90)), max=float(x.max()))

    idx, miss = v["index"], v["position_miss_m"]

    def by(x, edges):
        rows = []
        for lo, hi in zip(edges[:-1], edges[1:]):
            m = (x >= lo) & (x <= hi)
            rows.append(dict(range=[float(lo), float(hi)], n=int(m.sum()),
                             median_m=float(np.median(miss[m])) if m.any() else None,
                             max_m=float(miss[m].max()) if m.any() else None))
        return rows

    return dict(count=int(len(idx)), indices=idx.tolist(),
                fraction_within_1m=float(np.mean(miss <= 1.0)),
                fraction_within_100m=float(np.mean(miss <= 100.0)),
                position_miss_by_revolutions=by(params["revolutions"][idx],
                                                np.linspace(1.0, 5.0, 5)),
                position_miss_by_e=by(params["e"][idx], np.linspace(0.0, 0.7, 8)),
                propagator="propagate_nonlinear: two-body" + (" + J2" if args.model == "j2"
                                                             else "")
                           + ", Dopri8 rtol=atol=1e-12",
                integrator_ok=bool(np.all(v["integrator_ok"])),
                position_miss_m=dist(v["position_miss_m"]),
                velocity_miss_m_s=dist(v["velocity_miss_m_s"]),
                seconds_incl_compile=float(v["seconds"]))


# ------------------------------------------------------------------------------------------


def main(argv=None):
    args = parse_args(argv)
    args.cache.mkdir(parents=True, exist_ok=True)
    jax.config.update("jax_compilation_cache_dir", str(args.cache))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.5)
    out = args.out
    (out / "chunks").mkdir(parents=True, exist_ok=True)
    meta = dict(schema_version=SCHEMA_VERSION, n=args.n, seed=args.seed, chunk=args.chunk,
                model=args.model, n_points=args.points, options=str(args.options),
                dispersion="jaxlpm.cases.mei2010.dispersion(jax.random.key(seed), n, model)",
                command=" ".join([Path(sys.argv[0]).name] + sys.argv[1:]),
                started=time.strftime("%Y-%m-%d %H:%M:%S %Z"), machine=platform.node(),
                cpu_count=os.cpu_count(), jax=jax.__version__, git=git_state(),
                backend=jax.default_backend())
    check_meta(out, meta)

    problems = dispersion(jax.random.key(args.seed), args.n, model=args.model)
    params = dispersion_parameters(problems)
    grid = lgl(args.points)
    n_chunks = -(-args.n // args.chunk)
    path_of = lambda c: out / "chunks" / f"chunk_{c:05d}.npz"           # noqa: E731
    todo = [c for c in range(n_chunks) if not path_of(c).exists()]
    print(f"{args.n} problems ({args.model}), {n_chunks} chunks of {args.chunk} "
          f"(vmap width {args.vmap_width}); {n_chunks - len(todo)} already done in {out}",
          flush=True)

    def chunk_problems(c):
        idx = np.arange(c * args.chunk, min((c + 1) * args.chunk, args.n))
        pad = np.concatenate([idx, np.full(args.chunk - len(idx), idx[0])])
        return idx, take(problems, jnp.asarray(pad))

    timing_path = out / "timing.json"
    timing = json.loads(timing_path.read_text()) if timing_path.exists() else {}
    if todo:
        solver = make_chunk_solver(grid, args.vmap_width, args.chunk, args.options)
        t = time.time()
        compiled = solver.lower(chunk_problems(todo[0])[1]).compile()
        compile_s = time.time() - t
        timing.setdefault("compile_seconds", [])
        timing["compile_seconds"].append(compile_s)
        write_json_atomic(timing_path, timing)
        print(f"compile (incl. persistent-cache lookup): {compile_s:.1f} s", flush=True)
        bar = tqdm(todo, desc="chunks", unit="chunk", dynamic_ncols=True)
        n_done_ok = 0
        for c in bar:
            idx, batch = chunk_problems(c)
            t = time.time()
            r = jax.tree.map(np.asarray, jax.block_until_ready(compiled(batch)))
            dt = time.time() - t
            r = {k: v[: len(idx)] for k, v in r.items()}
            save_npz_atomic(path_of(c), index=idx, seconds=np.array(dt),
                            vmap_width=np.full(len(idx), args.vmap_width), **r)
            n_done_ok += int((r["status"] == Status.SUCCESS).sum())
            bar.set_postfix(s_per_chunk=f"{dt:.0f}", max_it=int(r["iterations"].max()),
                            failed=int((r["status"] != Status.SUCCESS).sum()))
        bar.close()

    files = [np.load(path_of(c)) for c in range(n_chunks)]
    rec = {k: np.concatenate([f[k] for f in files]) for k in files[0].files
           if k not in ("seconds", "iterations_padded_max")}
    rec["iterations_run"] = np.concatenate([lockstep_iterations(f, args) for f in files])
    assert np.array_equal(rec["index"], np.arange(args.n))
    timing["chunk_seconds"] = [float(f["seconds"]) for f in files]
    timing["compile_seconds"] = timing.get("compile_seconds", [])
    summary = summarise(rec, params, timing, args)
    summary["verification"] = verify(problems, rec, params, args, grid, out)
    summary["meta"] = json.loads((out / "meta.json").read_text())
    summary["finished"] = time.strftime("%Y-%m-%d %H:%M:%S %Z")
    write_json_atomic(out / "summary.json", summary)
    report(summary)
    print(f"\nwritten: {out / 'summary.json'}")


def report(s):
    print(f"\n=== Newton-KKT robustness: {s['n']} problems, model {s['model']}, seed {s['seed']}"
          f", {s['grid']} ===")
    print("status counts: " + ", ".join(f"{k} {v}" for k, v in sorted(s["status_counts"].items())))
    print(f"converged: {s['converged']}/{s['n']} = {100 * s['fraction_converged']:.2f} % "
          f"(target >= 99.9 %: {'met' if s['meets_target'] else 'NOT met'})")
    print(f"NaN without a status: {s['nan_without_status']} (outputs with NaN/inf: "
          f"{s['nan_or_inf_outputs']}, unknown status codes: {s['unknown_status_codes']})")
    it = s["iterations"]
    print(f"iterations: max {it['max']}, max among converged {it['max_converged']}, mean "
          f"converged {it['mean_converged']:.2f}, percentiles {it['percentiles_converged']}")
    print(f"iteration histogram: {it['histogram']}")
    if s["cost_m2_s3"]:
        print(f"cost (m^2/s^3) among converged: {s['cost_m2_s3']}")
        print(f"residuals among converged: {s['residuals_converged']}")
    print(f"largest excursion |rho| along the transfer (km): {s['max_excursion_km']}")
    t = s["timing"]
    comp = ", ".join(f"{x:.1f}" for x in t["compile_seconds"])
    print(f"timing: compile {comp} s; steady state {t['steady_seconds_total']:.1f} s over "
          f"{t['chunks']} chunks of {t['chunk_size']} (vmap width {t['vmap_width']}), "
          f"{t['steady_seconds_per_problem']:.3f} s/problem; per chunk "
          f"{t['steady_seconds_per_chunk']}; lockstep efficiency "
          f"{t['lockstep_efficiency']:.2f} (iterations used / iterations run)")
    print("failure rate by e:          " + "  ".join(
        f"[{r['range'][0]:.1f},{r['range'][1]:.1f}] {r['failed']}/{r['n']}"
        for r in s["failure_rate_by_e"]))
    print("failure rate by revolutions: " + "  ".join(
        f"[{r['range'][0]:.0f},{r['range'][1]:.0f}] {r['failed']}/{r['n']}"
        for r in s["failure_rate_by_revolutions"]))
    print("failure rate by |v0| (m/s):  " + "  ".join(
        f"[{r['range'][0]:.0f},{r['range'][1]:.0f}] {r['failed']}/{r['n']}"
        for r in s["failure_rate_by_speed_m_s"]))
    print("failure rate by log10 of the KKT residual at the warm start: " + "  ".join(
        f"[{max(r['range'][0], -99):.0f},{min(r['range'][1], 99):.0f}] {r['failed']}/{r['n']}"
        for r in s["failure_rate_by_log10_initial_kkt"]))
    if s["failures"]:
        print(f"\nnon-converged problems ({len(s['failures'])}):")
        print(f"{'idx':>5} {'status':>15} {'it':>3} {'e':>6} {'revs':>5} {'f0deg':>6} "
              f"{'|r0|km':>7} {'|v0|m/s':>7} {'kkt0':>8} {'max|rho|km':>10} {'|c|':>9} {'|gradL|':>9}")
        for f in s["failures"]:
            x0 = np.asarray(f["x0"])
            print(f"{f['index']:>5} {f['status']:>15} {f['iterations']:>3} {f['e']:6.3f} "
                  f"{f['revolutions']:5.2f} {f['f0_deg']:6.1f} "
                  f"{np.linalg.norm(x0[:3]) / 1e3:7.2f} {np.linalg.norm(x0[3:]):7.2f} "
                  f"{f['initial_kkt']:8.1e} "
                  f"{f['max_position_km']:10.1f} {f['constraint_residual']:9.2e} "
                  f"{f['stationarity_residual']:9.2e}")
    v = s["verification"]
    if v:
        print(f"\ntruth check ({v['count']} converged problems, {v['propagator']}; integrator "
              f"ok: {v['integrator_ok']}):")
        print(f"  terminal position miss (m):   {v['position_miss_m']}")
        print(f"  terminal velocity miss (m/s): {v['velocity_miss_m_s']}")
        print(f"  within 1 m: {100 * v['fraction_within_1m']:.1f} %, within 100 m: "
              f"{100 * v['fraction_within_100m']:.1f} %")
        for key, fmt in (("position_miss_by_revolutions", ".0f"), ("position_miss_by_e", ".1f")):
            print(f"  miss by {key.split('_by_')[1]}: " + "  ".join(
                f"[{r['range'][0]:{fmt}},{r['range'][1]:{fmt}}] n={r['n']} median "
                f"{r['median_m']:.2g} max {r['max_m']:.2g} m" for r in v[key] if r["n"]))


if __name__ == "__main__":
    main()
