"""Issue 19's acceptance run: the robustness dispersion solved with adaptive mesh refinement
at the default tolerance, every member flown by an independent integrator.

Problems: `jaxlpm.cases.mei2010.dispersion(jax.random.key(seed), n, model)` (the dispersion of
experiments/robustness_newton.py: e ~ U[0, 0.7], 1-5 revolutions, chaser within 25 km and
10 m/s per axis). Solver: `jaxlpm.batch.refine.refine_batch` (the default `MeshLadder`,
`DEFAULT_TOLERANCE`, Newton-KKT), in chunks of --chunk members, each chunk written to
OUT/chunk_XXXXX.npz as it finishes (a restarted run skips the chunks already there). Each
member's final solution is flown inside the compiled rung by `jaxlpm.verify.fly` (its own
model: two-body, or J2 on both spacecraft; Dopri8, rtol = atol = 1e-12), so the flown miss of
every member is recorded, not a sample. With --baseline the same problems are also solved on
the fixed grid lgl(65) (the robustness run's grid) for the time ratio, and flown.

    python experiments/robustness_refined.py --n 1000 --model two-body --baseline
    python experiments/robustness_refined.py --n 200 --model j2 --baseline

Summary (printed and OUT/summary.json): statuses, the SUCCESS fraction, the largest flown miss
of the SUCCESS members, the table by e and revolutions, wall time against the baseline (with
compiles and flights: every rung's members are flown, so a member refined three times flies
three times); --timing N adds the solve-only steady-state time of both on the first N
problems. --ladder KxN,KxN,... refines on another ladder of LGR meshes (segments x points per
segment; default the library's `DEFAULT_LADDER`, 4x16,4x32,8x32,16x32: the degree raised
first); `4x16,8x16,16x16,32x16` is the split-only ladder that was the default until
2026-12-07 (docs/accuracy.md, "Raising the degree or splitting").
"""

import argparse
import json
import time
from pathlib import Path

import jaxlpm as lpm
import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

from jaxlpm.batch import map_in_groups, save_npz_atomic, write_json_atomic  # noqa: E402
from jaxlpm.batch.refine import accuracy_record, refine_batch  # noqa: E402
from jaxlpm.solvers.refine import DEFAULT_LADDER, MeshLadder  # noqa: E402
from jaxlpm.cases.mei2010 import dispersion, dispersion_parameters  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent


def flown_record(solution):
    """`accuracy_record` plus the flown terminal miss [m, m/s] and plan error."""
    flight = lpm.verify.fly(solution)
    return dict(accuracy_record(solution), miss=flight.terminal_error,
                plan_error=flight.plan_error, flight_status=flight.status)


def _baseline_of(record):
    @jax.jit
    def baseline(problems):
        def one(p):
            return record(lpm.solve(p, lpm.lgl(65), method="newton", throw=False))
        return map_in_groups(one, problems, 1)
    return baseline


_baseline = _baseline_of(flown_record)


def parse_ladder(text):
    """A `MeshLadder` of LGR meshes from "4x16,8x16,...", or `DEFAULT_LADDER` for None."""
    if text is None:
        return DEFAULT_LADDER
    return MeshLadder(tuple(tuple(int(v) for v in rung.split("x")) for rung in text.split(",")))


def steady_timing(problems, ladder=DEFAULT_LADDER):
    """Solve-only wall time (no flights; compiled functions warmed up by a first pass):
    refinement against the fixed lgl(65) grid on the same problems, and the refinement's
    seconds per rung (rung_s)."""
    base = _baseline_of(accuracy_record)
    out = {}
    for name, run in (("refined_s", lambda: refine_batch(problems, ladder=ladder)),
                      ("baseline_s", lambda: jax.block_until_ready(base(problems)))):
        run()
        t = time.perf_counter()
        run()
        out[name] = time.perf_counter() - t
    out["ratio"] = out["refined_s"] / out["baseline_s"]
    # where the refined time goes: a third pass, each rung timed from refine_batch's log line
    # (written once the rung's records are on the host)
    stamps = [time.perf_counter()]
    refine_batch(problems, ladder=ladder, log=lambda line: stamps.append(time.perf_counter()))
    out["rung_s"] = np.diff(stamps).tolist()
    return out


def table(rec, params):
    e, rev = params["e"], params["revolutions"]
    rows = []
    for lo, hi in zip(np.arange(0.0, 0.71, 0.1)[:-1], np.arange(0.0, 0.71, 0.1)[1:]):
        for r0 in range(1, 5):
            m = (e >= lo) & (e < hi + (hi >= 0.7)) & (rev >= r0) & (rev < r0 + 1 + (r0 == 4))
            if not m.any():
                continue
            ok = rec["status"][m] == 0
            rows.append(dict(e=[round(lo, 1), round(hi, 1)], revolutions=[r0, r0 + 1],
                             n=int(m.sum()), success=int(ok.sum()),
                             max_miss_m=float(np.max(rec["miss"][m][ok, 0], initial=0.0)),
                             mean_rung=float(np.mean(rec["rung"][m]))))
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--chunk", type=int, default=100)
    ap.add_argument("--model", default="two-body", choices=("linear", "two-body", "j2"))
    ap.add_argument("--baseline", action="store_true", help="also solve on fixed lgl(65)")
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--timing", type=int, default=0,
                    help="also time the solves alone (no flights, steady state) on the first "
                         "TIMING problems")
    ap.add_argument("--ladder", default=None,
                    help="rungs as KxN,KxN,... (LGR segments x points; default DEFAULT_LADDER)")
    args = ap.parse_args(argv)
    ladder = parse_ladder(args.ladder)
    out = args.out or ROOT / "results" / f"robustness_refined_{args.model}_n{args.n}_s{args.seed}"
    out.mkdir(parents=True, exist_ok=True)
    problems = dispersion(jax.random.key(args.seed), args.n, model=args.model)
    params = {k: np.asarray(v) for k, v in dispersion_parameters(problems).items()}
    for start in range(0, args.n, args.chunk):
        path = out / f"chunk_{start:05d}.npz"
        if path.exists():
            continue
        idx = np.arange(start, min(start + args.chunk, args.n))
        chunk = jax.tree_util.tree_map(lambda x: x[idx], problems)
        t = time.perf_counter()
        rec = refine_batch(chunk, ladder=ladder, record=flown_record, log=print)
        t_ref = time.perf_counter() - t
        data = {f"refined_{k}": v for k, v in rec.items()}
        if args.baseline:
            t = time.perf_counter()
            base = jax.tree_util.tree_map(np.asarray, _baseline(chunk))
            t_base = time.perf_counter() - t
            data.update({f"baseline_{k}": v for k, v in base.items()})
        else:
            t_base = 0.0
        data.update(index=idx, time_refined=np.array([t_ref]), time_baseline=np.array([t_base]))
        save_npz_atomic(path, **data)
        print(f"chunk {start}: refined {t_ref:.1f} s, baseline {t_base:.1f} s", flush=True)
    files = [np.load(p) for p in sorted(out.glob("chunk_*.npz"))]
    rec = {k[len("refined_"):]: np.concatenate([f[k] for f in files])
           for k in files[0].files if k.startswith("refined_")}
    idx = np.concatenate([f["index"] for f in files])
    p = {k: v[idx] for k, v in params.items()}
    timing = {"refined_s": float(sum(f["time_refined"][0] for f in files)),
              "baseline_s": float(sum(f["time_baseline"][0] for f in files))}
    status = rec["status"]
    ok = status == 0
    summary = dict(
        n=int(idx.size), model=args.model, seed=args.seed, ladder=[list(r) for r in ladder.rungs],
        statuses={lpm.Status(int(s)).name: int((status == s).sum()) for s in np.unique(status)},
        success_fraction=float(ok.mean()),
        success_flown_within_tolerance=int(np.sum(ok & (rec["miss"][:, 0] <= 1.0)
                                                  & (rec["miss"][:, 1] <= 1e-3))),
        max_flown_miss_success=[float(np.max(rec["miss"][ok, 0], initial=0.0)),
                                float(np.max(rec["miss"][ok, 1], initial=0.0))],
        rungs={int(r): int((rec["rung"] == r).sum()) for r in np.unique(rec["rung"])},
        by_e_and_revolutions=table(rec, p), timing_s=timing,
        time_ratio=(timing["refined_s"] / timing["baseline_s"] if timing["baseline_s"] else None))
    if args.timing:
        summary["steady_timing"] = dict(
            n=args.timing, **steady_timing(jax.tree_util.tree_map(
                lambda x: x[:args.timing], problems), ladder))
    if "baseline_status" in files[0].files:
        b_status = np.concatenate([f["baseline_status"] for f in files])
        b_miss = np.concatenate([f["baseline_miss"] for f in files])
        summary["baseline"] = dict(
            statuses={lpm.Status(int(s)).name: int((b_status == s).sum())
                      for s in np.unique(b_status)},
            flown_miss_over_1m=int(np.sum(b_miss[:, 0] > 1.0)),
            max_flown_miss=float(np.max(b_miss[:, 0])))
    write_json_atomic(out / "summary.json", summary)
    print(json.dumps(summary, indent=1))


if __name__ == "__main__":
    main()
