"""Steady-state time of single solves through `jaxlpm.solve`, the path a research script takes
one problem at a time (issue 21: a solver compiled as several programs pays a dispatch per
program). Each case is solved once (compiling), then timed in k batches of n solves; the best
batch's mean per solve is reported (the least disturbed by other jobs on a shared VM).

Cases: mei2010's Newton-KKT transfer on lgl(65), two-body and J2; duan's minimum-time transfer
on lg(32); bench_refine's e = 0.6, 3-revolution two-body transfer refined by `solve(problem)`
(its whole mesh ladder); tan2011's impulsive intercept with its burn time optimised in
[23500, 24500] s, and its minimum-duration finite burn on lgl(5) and lgl(20) (each call also
solving its seed, the impulse at the paper's burn time, as `jaxlpm reproduce tan2011` does).

Run (repository root, or a checkout of an earlier commit to compare):
    PYTHONPATH=. python experiments/benchmarks/bench_steady_solve.py [--batches 7] [--only tan2011]
"""

import argparse
import os
import sys
import time

import jax

jax.config.update("jax_enable_x64", True)

sys.path.insert(0, os.path.dirname(__file__))

import jaxlpm as lpm  # noqa: E402
from jaxlpm.cases import duan, mei2010, tan2011  # noqa: E402


def best_mean(solve, n, k):
    """(first call s, best of k batches' mean time per solve s)."""
    t = time.perf_counter()
    jax.block_until_ready(solve().cost)
    first = time.perf_counter() - t
    means = []
    for _ in range(k):
        t = time.perf_counter()
        for _ in range(n):
            jax.block_until_ready(solve().cost)
        means.append((time.perf_counter() - t) / n)
    return first, min(means)


def cases():
    from bench_refine import eccentric_problem

    mei = mei2010.problem()
    for model in ("two-body", "j2"):
        p = mei.replace(model=model)
        yield (f"newton {model}, lgl(65)", 20,
               lambda p=p: lpm.solve(p, lpm.lgl(65), method="newton", throw=False))
    yield "min-time duan, lg(32)", 20, lambda: lpm.solve(duan.problem(), lpm.lg(32), throw=False)
    refined = eccentric_problem()
    yield "refined e = 0.6, 3 revolutions", 5, lambda: lpm.solve(refined, throw=False)
    elements, _ = tan2011.recover_elements()
    window = tan2011.problem(elements, [23500.0, 24500.0], revolutions=3, branch="left")
    yield "tan2011 burn time optimised", 5, lambda: lpm.solve(window, throw=False)
    burn = tan2011.finite_burn_problem(tan2011.problem(elements))
    for n in (5, 20):
        yield (f"tan2011 finite burn, lgl({n})", 2,
               lambda n=n: lpm.solve(burn, lpm.lgl(n), throw=False))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--batches", type=int, default=7)
    ap.add_argument("--only", default="", help="run the cases whose name contains this")
    args = ap.parse_args(argv)
    for name, n, solve in cases():
        if args.only not in name:
            continue
        first, best = best_mean(solve, n, args.batches)
        print(f"{name:<34} first call {first:6.1f} s   steady {1e3 * best:8.2f} ms "
              f"(best of {args.batches} x {n})", flush=True)


if __name__ == "__main__":
    main()
