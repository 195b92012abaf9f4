"""Raising the degree or splitting (issue 19): the refinement of one batch on mesh ladders that
differ in how a rung adds points, timed side by side in one process.

Problems: the first --n members of mei2010's dispersion (`jaxlpm.cases.mei2010.dispersion`,
key 0; e in [0, 0.7], 1-5 revolutions) on --model. Ladders (LGR; segments x points per
segment):
  p then h   4 x 16, 4 x 32, 8 x 32, 16 x 32   (the default `DEFAULT_LADDER`)
  h          4 x 16, 8 x 16, 16 x 16, 32 x 16  (split only: the default until 2026-12-07)
  h, p, h    4 x 16, 8 x 16, 8 x 32, 16 x 32
Each is run once by `jaxlpm.batch.refine.refine_batch` (compiling the rungs that no ladder
before it compiled: its first-pass time is not a compile comparison; the members per final
rung and the statuses printed), then --repeats times more, the ladders alternating, in steady
state (the noise of a shared VM falls on all of them alike).

Run:  PYTHONPATH=. python experiments/benchmarks/bench_ladders.py [--n 250] [--model two-body]
      [--repeats 3] [--out results/bench_ladders.json]
"""

import argparse
import json
import time
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

from jaxlpm.batch.refine import refine_batch  # noqa: E402
from jaxlpm.cases.mei2010 import dispersion  # noqa: E402
from jaxlpm.solvers.refine import MeshLadder  # noqa: E402

LADDERS = {"p then h": ((4, 16), (4, 32), (8, 32), (16, 32)),
           "h": ((4, 16), (8, 16), (16, 16), (32, 16)),
           "h, p, h": ((4, 16), (8, 16), (8, 32), (16, 32))}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=250)
    ap.add_argument("--model", default="two-body", choices=("linear", "two-body", "j2"))
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    problems = dispersion(jax.random.key(0), args.n, model=args.model)
    results = {}
    for name, rungs in LADDERS.items():
        t = time.perf_counter()
        out = refine_batch(problems, ladder=MeshLadder(rungs))
        results[name] = dict(
            rungs=[list(r) for r in rungs], first_pass_s=time.perf_counter() - t,
            members_per_rung=np.bincount(out["rung"], minlength=len(rungs)).tolist(),
            success=int(np.sum(out["status"] == 0)), steady_s=[])
        print(f"{name}: first pass {results[name]['first_pass_s']:.1f} s, members per final "
              f"rung {results[name]['members_per_rung']}, SUCCESS {results[name]['success']}"
              f" / {args.n}", flush=True)
    for _ in range(args.repeats):
        for name, rungs in LADDERS.items():
            t = time.perf_counter()
            refine_batch(problems, ladder=MeshLadder(rungs))
            results[name]["steady_s"].append(time.perf_counter() - t)
    for name, r in results.items():
        print(f"{name}: steady {', '.join(f'{x:.2f}' for x in r['steady_s'])} s", flush=True)
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(dict(n=args.n, model=args.model, ladders=results),
                                       indent=1))


if __name__ == "__main__":
    main()
