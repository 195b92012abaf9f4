"""Cold start (issue 21): what the first solve of each family and each reproduction spends on
tracing, lowering and compiling, from an empty cache and from a warm one.

1. Entry points. Each runs in a fresh process whose JAX persistent cache and jaxlpm
   executable cache (`jaxlpm.compilation`) point at one folder: first empty ("cold"), then
   again with the folder the cold run filled ("warm"). Per run: the wall time of the first
   call through the public API (`jaxlpm.solve`, `jaxlpm.verify.fly`), of a second call
   (steady state), and from `jaxlpm.compilation.events` the trace, lower and compile times
   and the lowered StableHLO's size (lines) of every program it compiled, or the time it
   took to load it from disk. --profiles runs each with JAXLPM_COMPILE=fast (the default)
   and =optimized (XLA's default options: how `solve` compiled before issue 21).
2. Reproductions (--reproduce mei2010,duan,...): `jaxlpm reproduce <case>` wall time in a
   fresh process, cold then warm, and the longest gap between two lines it printed (the
   progress it shows). --source DIR runs them from another checkout (the commit before the
   change, for the before/after table).
3. --plain-newton: the first Newton-KKT transfer (mei2010, lgl(65), on the two-body and J2
   models) timed by its wall time alone (first call, then a second call), in a fresh process
   from the --source checkout with an empty cache: the form that also runs on checkouts from
   before `jaxlpm.compilation` (its trace and compile times are not reported).
4. The CasADi side by side (--casadi): the first Newton-KKT transfer (mei2010 on the
   two-body model, lgl(65), 585 unknowns) compiled and solved cold by jaxlpm in a fresh
   process, against CasADi building the same NLP (bench_newton.build_ipopt: SX, IPOPT with
   exact Hessian) and solving it once from the same start, also in a fresh process.
Imports are timed apart from the first call.

Run:  PYTHONPATH=. python experiments/benchmarks/bench_compile.py [--entries all]
      [--profiles fast,optimized] [--reproduce mei2010] [--source DIR] [--plain-newton]
      [--casadi] [--out results/bench_compile.json]
"""

import argparse
import collections
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]

ENTRIES = ("kkt", "stm", "newton-two-body", "newton-j2", "fly", "min-time", "fuel", "lqr",
           "impulsive")

CHILD = r'''
import json, sys, time
t0 = time.perf_counter()
import jax
jax.config.update("jax_enable_x64", True)
import jaxlpm as lpm
from jaxlpm import compilation
compilation.record_hlo = sys.argv[2] == "cold"
t_import = time.perf_counter() - t0
entry = sys.argv[1]


def setup():
    if entry in ("kkt", "stm", "newton-two-body", "newton-j2", "fly"):
        from jaxlpm.cases import mei2010
        p = mei2010.problem()
        if entry == "fly":
            sol = lpm.solve(p, lpm.lgl(65), method="kkt", throw=False)
            compilation.events.clear()
            return lambda: lpm.verify.fly(sol).terminal_error
        method = "newton" if entry.startswith("newton") else entry
        if method == "newton":
            p = p.replace(model=entry.split("-", 1)[1])
        return lambda: lpm.solve(p, lpm.lgl(65), method=method, throw=False).cost
    if entry == "min-time":
        from jaxlpm.cases import duan
        p = duan.problem()
        return lambda: lpm.solve(p, lpm.lg(32), throw=False).cost
    if entry == "fuel":
        from jaxlpm.cases import yue2016
        p = jax.tree_util.tree_map(lambda x: x[0], yue2016.problems())
        mesh = lpm.segmented_lgr(lpm.uniform_breaks(0.0, 1.0, 24), 8)
        return lambda: lpm.solve(p, mesh, throw=False).cost
    if entry == "lqr":
        from jaxlpm.cases import jiang2011
        Q, R = jiang2011.weights()
        p = lpm.LQRTransfer(jiang2011.chief(), jiang2011.initial_state(), 3000.0, Q, R,
                            terminal="hard")
        return lambda: lpm.solve(p, throw=False).cost
    if entry == "impulsive":
        from jaxlpm.cases import tan2011
        p = tan2011.problem()
        return lambda: lpm.solve(p, throw=False).cost
    raise SystemExit(f"unknown entry {entry}")


call = setup()
t = time.perf_counter()
jax.block_until_ready(call())
first = time.perf_counter() - t
t = time.perf_counter()
jax.block_until_ready(call())
second = time.perf_counter() - t
print(json.dumps(dict(import_s=t_import, first_call_s=first, second_call_s=second,
                      events=compilation.events)))
'''

PLAIN_CHILD = r'''
import json, sys, time
t0 = time.perf_counter()
import jax
jax.config.update("jax_enable_x64", True)
import jaxlpm as lpm
from jaxlpm.cases import mei2010
t_import = time.perf_counter() - t0
p = mei2010.problem().replace(model=sys.argv[1])


def call():
    return lpm.solve(p, lpm.lgl(65), method="newton", throw=False).cost


t = time.perf_counter()
jax.block_until_ready(call())
first = time.perf_counter() - t
t = time.perf_counter()
jax.block_until_ready(call())
print(json.dumps(dict(import_s=t_import, first_call_s=first,
                      second_call_s=time.perf_counter() - t)))
'''

CASADI_CHILD = r'''
import json, sys, time
t0 = time.perf_counter()
sys.path.insert(0, "experiments/benchmarks")
import numpy as np
import bench_newton as bn
from jaxlpm import lgl
import jax
t_import = time.perf_counter() - t0
grid = lgl(65)
prob = bn.single_problem()
d = bn.host(bn.peer_data(prob, grid))     # jaxlpm's numbers for the peer, not timed
t = time.perf_counter()
solver, funcs, build_s, size = bn.build_ipopt(np.asarray(grid.D), np.asarray(grid.weights))
built = time.perf_counter() - t
first = bn.ipopt_solve(solver, d)
second = bn.ipopt_solve(solver, d)
print(json.dumps(dict(import_s=t_import, build_s=built, nlpsol_s=build_s,
                      first_solve_s=first["wall_s"], second_solve_s=second["wall_s"],
                      status=first["status"], iterations=first["iterations"],
                      variables=size[0], constraints=size[1])))
'''


def _env(cache, profile=None, source=ROOT):
    env = dict(os.environ, JAXLPM_CACHE_DIR=str(cache), PYTHONPATH=str(source))
    if profile:
        env["JAXLPM_COMPILE"] = profile
    return env


def _child(code, args, env, cwd=ROOT):
    out = subprocess.run([sys.executable, "-c", code, *args], env=env, cwd=cwd,
                         capture_output=True, text=True, timeout=3600)
    if out.returncode != 0:
        return dict(error=out.stderr[-2000:])
    return json.loads(out.stdout.strip().splitlines()[-1])


def _summarise(run):
    ev = run.get("events", [])
    comp = [e for e in ev if e["source"] == "compiled"]
    return dict(first_call_s=run.get("first_call_s"), second_call_s=run.get("second_call_s"),
                import_s=run.get("import_s"), programs_compiled=len(comp),
                programs_loaded=len(ev) - len(comp),
                trace_s=sum(e["trace_s"] for e in comp), lower_s=sum(e["lower_s"] for e in comp),
                compile_s=sum(e["compile_s"] for e in comp),
                load_s=sum(e.get("load_s", 0.0) for e in ev),
                hlo_lines=sum(e.get("hlo_lines", 0) for e in comp), error=run.get("error"))


def entry_points(entries, profiles):
    rows = []
    for profile in profiles:
        for entry in entries:
            with tempfile.TemporaryDirectory() as cache:
                cold = _child(CHILD, [entry, "cold"], _env(cache, profile))
                warm = _child(CHILD, [entry, "warm"], _env(cache, profile))
            row = dict(entry=entry, profile=profile, cold=_summarise(cold),
                       warm=_summarise(warm))
            rows.append(row)
            print(_entry_line(row), flush=True)
    return rows


def _entry_line(r):
    c, w = r["cold"], r["warm"]
    if c["error"] or w["error"]:
        return f"{r['entry']:<16}{r['profile']:<10} error: {(c['error'] or w['error'])[-300:]}"
    return (f"{r['entry']:<16}{r['profile']:<10}{c['first_call_s']:>8.2f}{c['trace_s']:>8.2f}"
            f"{c['lower_s']:>8.2f}{c['compile_s']:>9.2f}{c['hlo_lines']:>9d}"
            f"{c['second_call_s']:>10.4f}{w['first_call_s']:>9.2f}{w['load_s']:>8.2f}")


ENTRY_HEADER = (f"{'entry':<16}{'profile':<10}{'cold 1st':>8}{'trace':>8}{'lower':>8}"
                f"{'compile':>9}{'HLO':>9}{'steady':>10}{'warm 1st':>9}{'load':>8}")


def reproduce(cases, source):
    rows = []
    for case in cases:
        with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as out:
            row = dict(case=case, source=str(source))
            for kind in ("cold", "warm"):
                row[kind] = _timed_cli(case, _env(cache, source=source), out, source)
            rows.append(row)
            print(f"{case:<10} cold {row['cold']['wall_s']:7.1f} s (longest silence "
                  f"{row['cold']['longest_gap_s']:5.1f} s){_failed(row['cold'])}   warm "
                  f"{row['warm']['wall_s']:6.1f} s (longest silence "
                  f"{row['warm']['longest_gap_s']:5.1f} s){_failed(row['warm'])}", flush=True)
            for kind in ("cold", "warm"):
                if row[kind]["returncode"] != 0:
                    print("\n".join(f"  {kind}: {line}" for line in row[kind]["tail"]),
                          flush=True)
    return rows


def _timed_cli(case, env, out, source):
    t0 = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-m", "jaxlpm.cli", "reproduce", case, "--out",
                             out], env=env, cwd=source, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    last, gap, tail = t0, 0.0, collections.deque(maxlen=5)
    for line in proc.stdout:
        now = time.perf_counter()
        gap, last = max(gap, now - last), now
        tail.append(line.rstrip())
    proc.wait()
    end = time.perf_counter()
    return dict(wall_s=end - t0, longest_gap_s=max(gap, end - last), returncode=proc.returncode,
                tail=list(tail))


def _failed(run):
    """A run that did not finish is not a time: say so beside it."""
    return "" if run["returncode"] == 0 else f" FAILED (exit {run['returncode']})"


def plain_newton(source):
    rows = []
    for model in ("two-body", "j2"):
        with tempfile.TemporaryDirectory() as cache:
            run = _child(PLAIN_CHILD, [model], _env(cache, source=source), cwd=source)
        rows.append(dict(model=model, source=str(source), **run))
        if run.get("error"):
            print(f"newton {model:<9} error: {run['error'][-300:]}", flush=True)
        else:
            print(f"newton {model:<9} first call {run['first_call_s']:6.2f} s, second "
                  f"{run['second_call_s']:.4f} s (import {run['import_s']:.2f} s)", flush=True)
    return rows


def casadi_side_by_side():
    with tempfile.TemporaryDirectory() as cache:
        ours = _child(CHILD, ["newton-two-body", "cold"], _env(cache))
    peer = _child(CASADI_CHILD, [], _env(tempfile.gettempdir()))
    res = dict(ours=_summarise(ours), casadi=peer)
    if not ours.get("error") and not peer.get("error"):
        res["ratio_first_solve"] = ours["first_call_s"] / (peer["build_s"]
                                                           + peer["first_solve_s"])
        print(f"first Newton-KKT transfer, cold: jaxlpm {ours['first_call_s']:.2f} s (compile "
              f"+ solve) vs CasADi {peer['build_s']:.2f} s build + {peer['first_solve_s']:.2f} "
              f"s IPOPT: {res['ratio_first_solve']:.1f}x", flush=True)
    else:
        print(res, flush=True)
    return res


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--entries", default="all", help=f"comma-separated of {ENTRIES}, or none")
    ap.add_argument("--profiles", default="fast")
    ap.add_argument("--reproduce", default="", help="comma-separated cases")
    ap.add_argument("--source", default=str(ROOT), help="checkout the reproductions run from")
    ap.add_argument("--plain-newton", action="store_true",
                    help="the first Newton-KKT transfer's wall time from --source")
    ap.add_argument("--casadi", action="store_true")
    ap.add_argument("--out", default="results/bench_compile.json")
    args = ap.parse_args(argv)
    sys.path.insert(0, str(ROOT / "experiments" / "benchmarks"))
    from common import machine_info

    entries = (ENTRIES if args.entries == "all" else
               () if args.entries == "none" else tuple(args.entries.split(",")))
    res = dict(schema_version=1, date_utc=time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
               machine=machine_info())
    if entries:
        print(ENTRY_HEADER)
        res["entry_points"] = entry_points(entries, args.profiles.split(","))
    if args.reproduce:
        res["reproduce"] = reproduce(args.reproduce.split(","), Path(args.source).resolve())
    if args.plain_newton:
        res["plain_newton"] = plain_newton(Path(args.source).resolve())
    if args.casadi:
        res["casadi"] = casadi_side_by_side()
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(res, indent=2))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
