"""Stress test of the batched value-and-gradient paths for hangs (issue 17, defect 7).

jaxlib 0.10's batched CPU LAPACK kernels split a batch over XLA's intra-op thread pool and
block until it is done (`jax::ParallelBatchMap`); two such calls at once deadlock a 2-thread
pool (`jaxlpm.linalg.sequential_when_batched`). This script runs

    jax.jit(jax.vmap(jax.value_and_grad(lambda e: solve(problem(e), grid, method=method).cost)))

for the STM and KKT laws (linear model, lgl(--n-laws)) and the Newton transfer (models
"linear" and "two-body", lgl(--n-newton)) over eccentricities e = linspace(0.05, E_MAX, B),
shifted per call (E_MAX = 0.3: perigee above the Earth's surface, a = 9500 km, so the
nonlinear model accepts every member). With k --cases, call i runs case i mod k with batch size
B = --batches[(i // k) mod len], in its own subprocess: compile (persistent cache:
JAXLPM_CACHE_DIR, else ~/.cache/jaxlpm/jax), one blocking execution, then --repeats
executions dispatched back to back before blocking (asynchronous dispatch, as a user's loop
would). --no-workaround runs the subprocesses with XLA's concurrency-optimised scheduler on
(`jaxlpm._cpu_runtime` respects a value in XLA_FLAGS): a path free of batched LAPACK calls
must not hang without the workaround either.

A call is a hang when its process uses under 1 % of a core over --stall-s seconds (a
deadlocked pool waits at 0 %; one thread still wakes for 10 ms every ~30 s) or runs past
--timeout-s; its threads' backtraces are then saved with gdb (when
installed) to OUT's name + _hang_<call>.txt and the process is killed. Each finished call is
appended to OUT (JSONL) at once; a rerun with the same plan skips the calls already there
(resumable). The summary (hangs, errors, non-finite gradients, timings per case) is printed
at the end; the exit status is 1 if any call hung or failed.

Run from the repository root (about 1 min per 10 calls on 2 cores once compiled):
    python experiments/stress_batched.py --calls 120 --out results/stress_batched.jsonl
"""

import argparse
import collections
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CASES = ("stm/linear", "kkt/linear", "newton/linear", "newton/two-body")     # method/model
SCHEDULER_ON = "--xla_cpu_enable_concurrency_optimized_scheduler=true"
X0 = [10000.0, 10000.0, 500.0, 4.0, -23.485, 0.3]       # LVLH m, m/s; rendezvous at the origin
E_MAX = 0.3
IDLE = 0.01                          # CPU fraction of one core below which a call is stalled


def plan(args):
    """The calls, in order: dicts of index, method, model, n (LGL points), batch, e_max,
    repeats, shift, workaround."""
    calls = []
    for i in range(args.calls):
        method, model = args.cases[i % len(args.cases)].split("/")
        calls.append(dict(index=i, method=method, model=model,
                          n=args.n_laws if method != "newton" else args.n_newton,
                          batch=args.batches[(i // len(args.cases)) % len(args.batches)],
                          e_max=E_MAX, repeats=args.repeats, shift=1e-4 * i,
                          workaround=not args.no_workaround))
    return calls


def worker(call):
    """One call, in this process: prints its record (timings, statuses, finiteness) as JSON."""
    t0 = time.perf_counter()
    from jaxlpm import EnergyOptimalTransfer, KeplerOrbit, lgl, solve  # its CPU settings first
    import jax
    import jax.numpy as jnp
    import numpy as np

    jax.config.update("jax_enable_x64", True)
    jax.config.update("jax_compilation_cache_dir", os.environ.get(
        "JAXLPM_CACHE_DIR", str(Path.home() / ".cache" / "jaxlpm" / "jax")))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.5)
    grid = lgl(call["n"])

    def cost(e):
        orbit = KeplerOrbit(a=jnp.asarray(9500e3), e=e, f0=jnp.asarray(0.2))
        prob = EnergyOptimalTransfer.from_revolutions(orbit, jnp.asarray(X0), jnp.zeros(6),
                                                      1.0, model=call["model"])
        sol = solve(prob, grid, method=call["method"])
        return sol.cost, sol.status

    es = jnp.linspace(0.05, call["e_max"], call["batch"]) + call["shift"]
    t1 = time.perf_counter()
    f = jax.jit(jax.vmap(jax.value_and_grad(cost, has_aux=True))).lower(es).compile()
    t2 = time.perf_counter()
    (c, status), g = jax.block_until_ready(f(es))
    t3 = time.perf_counter()
    outs = [f(es + 1e-6 * (k + 1)) for k in range(call["repeats"])]
    jax.block_until_ready(outs)
    t4 = time.perf_counter()
    finite = all(bool(np.all(np.isfinite(np.asarray(x)))) for o in [((c, status), g)] + outs
                 for x in jax.tree_util.tree_leaves(o))
    codes, counts = np.unique(np.asarray(status), return_counts=True)
    print(json.dumps(dict(import_s=t1 - t0, compile_s=t2 - t1, first_s=t3 - t2,
                          repeats_s=t4 - t3, finite=finite,
                          status_counts={int(k): int(v) for k, v in zip(codes, counts)})))


def _cpu_ticks(pid):
    """utime + stime of process pid (clock ticks, all threads), or None once it is gone."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except (FileNotFoundError, ProcessLookupError):
        return None
    return int(fields[11]) + int(fields[12])


def _save_backtraces(pid, path):
    """Every thread's stack of process pid, by gdb, into path; path, or None without gdb."""
    if not shutil.which("gdb"):
        return None
    with open(path, "w") as fh:
        try:
            subprocess.run(["gdb", "-p", str(pid), "-batch", "-ex", "set debuginfod enabled off",
                            "-ex", "thread apply all bt 16"], stdout=fh,
                           stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, timeout=300)
        except subprocess.TimeoutExpired:
            fh.write("\n(gdb timed out)\n")
    return str(path)


def run_call(call, args, out_path):
    """Run one call in a subprocess under the watchdog; its record."""
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        t0 = time.perf_counter()
        env = dict(os.environ)
        if not call["workaround"]:
            env["XLA_FLAGS"] = f"{env.get('XLA_FLAGS', '')} {SCHEDULER_ON}".strip()
        proc = subprocess.Popen([sys.executable, __file__, "--worker", json.dumps(call)],
                                stdout=out, stderr=err, text=True, env=env)
        per_s, why = os.sysconf("SC_CLK_TCK"), None
        samples = collections.deque([(time.perf_counter(), _cpu_ticks(proc.pid))])
        while proc.poll() is None:
            time.sleep(1.0)
            now, ticks = time.perf_counter(), _cpu_ticks(proc.pid)
            if ticks is None:
                continue
            samples.append((now, ticks))
            while now - samples[1][0] >= args.stall_s:      # keep one sample >= stall_s old
                samples.popleft()
            window, used = now - samples[0][0], (ticks - samples[0][1]) / per_s
            if window >= args.stall_s and used < IDLE * window:
                why = f"{100 * used / window:.2f} % CPU over {window:.0f} s"
            elif now - t0 > args.timeout_s:
                why = f"still running after {args.timeout_s:.0f} s"
            if why and proc.poll() is None:
                backtrace = _save_backtraces(proc.pid, out_path.with_name(
                    f"{out_path.stem}_hang_{call['index']:05d}.txt"))
                proc.kill()
                proc.wait()
                return dict(call, outcome="hang", reason=why, backtrace=backtrace,
                            wall_s=time.perf_counter() - t0)
        wall = time.perf_counter() - t0
        out.seek(0)
        err.seek(0)
        lines = out.read().strip().splitlines()
        if proc.returncode != 0 or not lines:
            return dict(call, outcome="error", returncode=proc.returncode,
                        stderr_tail=err.read()[-2000:], wall_s=wall)
        return dict(call, outcome="ok", wall_s=wall, **json.loads(lines[-1]))


def summary(records):
    """Counts and timings over the records: a dict, and its lines for printing."""
    n = len(records)
    hangs = [r for r in records if r["outcome"] == "hang"]
    errors = [r for r in records if r["outcome"] == "error"]
    ok = [r for r in records if r["outcome"] == "ok"]
    res = dict(calls=n, executions_completed=sum(1 + r["repeats"] for r in ok),
               hangs=len(hangs), errors=len(errors),
               nonfinite=sum(not r["finite"] for r in ok), cases={})
    lines = [f"hangs: {len(hangs)} of {n} calls ({res['executions_completed']} executions "
             f"completed); "
             f"errors: {len(errors)}; calls with non-finite values or gradients: "
             f"{res['nonfinite']}"]
    for case in CASES:
        rs = [r for r in ok if f"{r['method']}/{r['model']}" == case]
        if not rs:
            continue
        status = {}
        for r in rs:
            for k, v in r["status_counts"].items():
                status[k] = status.get(k, 0) + v
        per_member = [r["repeats_s"] / (r["repeats"] * r["batch"]) for r in rs if r["repeats"]]
        stats = dict(calls=len(rs), batches=sorted({r["batch"] for r in rs}),
                     compile_s_median=statistics.median(r["compile_s"] for r in rs),
                     first_s_median=statistics.median(r["first_s"] for r in rs),
                     per_member_ms_median=1e3 * statistics.median(per_member) if per_member
                     else None, status_counts=status)
        res["cases"][case] = stats
        lines.append(f"  {case} lgl({rs[0]['n']}): {len(rs)} calls, batches "
                     f"{stats['batches']}, compile {stats['compile_s_median']:.1f} s, first run "
                     f"{stats['first_s_median']:.2f} s, "
                     + (f"{stats['per_member_ms_median']:.2f} ms per member and value-and-"
                        f"gradient (median), " if per_member else "")
                     + f"statuses {status}")
    for r in hangs + errors:
        lines.append(f"  call {r['index']} {r['method']}/{r['model']} batch {r['batch']}: "
                     f"{r['outcome']} ({r.get('reason') or r.get('stderr_tail', '')[-300:]})")
    return res, lines


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="results/stress_batched.jsonl")
    ap.add_argument("--calls", type=int, default=120)
    ap.add_argument("--cases", default=",".join(CASES), help="method/model, comma separated")
    ap.add_argument("--batches", default="1,3,16,64,100,128",
                    help="batch sizes, comma separated, cycled over")
    ap.add_argument("--n-laws", type=int, default=65, help="LGL points for stm and kkt")
    ap.add_argument("--n-newton", type=int, default=17, help="LGL points for newton")
    ap.add_argument("--repeats", type=int, default=3,
                    help="executions dispatched back to back after the first")
    ap.add_argument("--stall-s", type=float, default=60.0)
    ap.add_argument("--timeout-s", type=float, default=900.0)
    ap.add_argument("--no-workaround", action="store_true",
                    help="XLA's concurrency-optimised scheduler on in the subprocesses")
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        return worker(json.loads(args.worker))
    args.batches = [int(b) for b in args.batches.split(",")]
    args.cases = args.cases.split(",")
    unknown = sorted(set(args.cases) - set(CASES))
    if unknown:
        ap.error(f"unknown cases {unknown}; choose from {list(CASES)}")
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    calls = plan(args)
    done = {}
    if out.exists():
        for line in out.read_text().splitlines():
            if line.strip():
                r = json.loads(line)
                done[r["index"]] = r
    for i, r in done.items():
        if i >= len(calls) or any(r[k] != v for k, v in calls[i].items()):
            spec = {k: r.get(k) for k in calls[0]}
            sys.exit(f"{out} holds call {i} of another plan ({spec}); use another --out")
    todo = [c for c in calls if c["index"] not in done]
    print(f"{len(calls)} calls planned, {len(done)} already in {out}, {len(todo)} to run",
          flush=True)
    with open(out, "a") as fh:
        for call in todo:
            r = run_call(call, args, out)
            fh.write(json.dumps(r) + "\n")
            fh.flush()
            os.fsync(fh.fileno())
            done[call["index"]] = r
            print(f"call {call['index']} {call['method']}/{call['model']} batch "
                  f"{call['batch']}: {r['outcome']}, {r['wall_s']:.1f} s", flush=True)
    res, lines = summary([done[c["index"]] for c in calls])
    print("\n".join(lines))
    return 1 if res["hangs"] or res["errors"] else 0


if __name__ == "__main__":
    sys.exit(main())
