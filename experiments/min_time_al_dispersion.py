"""Minimum time by the augmented Lagrangian on the chief's true anomaly against method
"condensed" over a dispersion of eccentric transfers (issue 19).

The members: experiments/benchmarks/bench_min_time.py's dispersion (seed 0: chief perigee
radius 7000 km, e uniform in [0, 0.5], from rest at the chief to rest at a point uniform in a
box of +-4 km radial and along-track, +-1 km normal; 0.1 N on 50 kg, t_max 5 chief periods),
on the linear model (--model two-body: the same ends on the two-body model). Each member is
solved three ways:

  condensed    method "condensed" on 16 x 8 LG segments (the reference: the states
               eliminated, the reachable set's support function, a fallback where its Newton
               on T wanders)
  al_lg        method "augmented-lagrangian" on the same 16 x 8 LG mesh (the states kept,
               Newton-KKT with the free final anomaly): one discrete problem, two algorithms
  al_lgl       method "augmented-lagrangian" refined on the LGL ladder 1 x 32, 2 x 48, 4 x 48
               (the default there; what method "condensed" cannot take)

Each line of the output (JSON, one member per line, written as it goes; a rerun skips the
members already there) holds the statuses, durations and error estimates; the summary
counts the statuses and gives the largest relative difference of t_f from the reference
where both are SUCCESS.

    python experiments/min_time_al_dispersion.py [--members 16] [--model two-body]
"""

import argparse
import json
import os
import sys
import time
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "benchmarks"))
from bench_min_time import dispersion  # noqa: E402
from common import member  # noqa: E402

import jaxlpm as lpm  # noqa: E402

RESULTS = Path(__file__).parent / "results"
LG_MESH = lpm.segmented_lg(lpm.uniform_breaks(0.0, 1.0, 16), 8)
LGL_LADDER = lpm.MeshLadder(((1, 32), (2, 48), (4, 48)), scheme="LGL")


def solve_three_ways(problem) -> dict:
    row = {}
    for name, grid, method in (("condensed", LG_MESH, "condensed"),
                               ("al_lg", LG_MESH, "augmented-lagrangian"),
                               ("al_lgl", LGL_LADDER, None)):
        t = time.perf_counter()
        sol = lpm.solve(problem, grid, method=method, throw=False)
        row[name] = dict(status=lpm.Status(int(sol.status)).name,
                         duration=float(sol.duration),
                         error_position=float(sol.stats["error_position"]),
                         seconds=time.perf_counter() - t)
    return row


def summary(rows):
    print(f"{len(rows)} members")
    for name in ("condensed", "al_lg", "al_lgl"):
        counts = {}
        for r in rows:
            counts[r[name]["status"]] = counts.get(r[name]["status"], 0) + 1
        print(f"  {name}: {dict(sorted(counts.items()))}")
    for name in ("al_lg", "al_lgl"):
        both = [r for r in rows if r[name]["status"] == r["condensed"]["status"] == "SUCCESS"]
        rel = [abs(r[name]["duration"] - r["condensed"]["duration"]) / r["condensed"]["duration"]
               for r in both]
        if rel:
            print(f"  {name} vs condensed, both SUCCESS ({len(both)}): largest |dt_f| / t_f "
                  f"{max(rel):.1e}, median {float(np.median(rel)):.1e}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--members", type=int, default=16)
    parser.add_argument("--model", default="linear", choices=("linear", "two-body"))
    args = parser.parse_args()
    out = RESULTS / f"min_time_al_dispersion_{args.model}.jsonl"
    RESULTS.mkdir(exist_ok=True)
    done = [json.loads(line) for line in out.read_text().splitlines()] if out.exists() else []
    batch = dispersion(jax.random.PRNGKey(0), args.members).replace(model=args.model)
    with out.open("a") as f:
        for i in range(len(done), args.members):
            row = dict(member=i, e=float(batch.orbit.e[i]),
                       **solve_three_ways(member(batch, i)))
            done.append(row)
            f.write(json.dumps(row) + "\n")
            f.flush()
            print(json.dumps(row), flush=True)
    summary(done[:args.members])


if __name__ == "__main__":
    main()
