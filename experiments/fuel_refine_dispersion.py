"""The fuel-optimal family's default solve (`jaxlpm.solve(problem)`: meshes aligned with the
switches, `jaxlpm.solvers.fuel_optimal.refine_transfer`) over a dispersion of transfers on the
linear model, and with --constrained over keep-out flybys (method "augmented-lagrangian"):
per member the status, the meshes it took, the largest thrust excess between the nodes and the
flown miss; then the count by status. Each member is printed as it is solved.

Unconstrained members: e in [0, 0.5], from rest at the chief to rest at a point y in
+-[2, 10] km along-track and x, z in +-500 m, in 0.5 to 1.5 periods, 0.1 to 0.5 N on 50 kg
(Isp 1000 s) (seed 0). Constrained members: the flyby of tests/test_fuel_constrained.py
(e = 0.05, 0.5 N on 100 kg, half a period) with the sphere's radius in [1000, 1800] m, e in
[0, 0.15] and the duration in [0.4, 0.6] periods (seed 0).

With --at-switches every break stays at its switch (no `switch_margins`: the refinement
until 2026-12-07), for a side-by-side comparison; --scheme LGR (LG, LGL) refines on the
family's ladder of those segments instead of its own (LG unconstrained, LGR constrained; on
LGL segments by method "augmented-lagrangian", the states kept).
With --batch the members are refined together by `jaxlpm.batch.refine.refine_batch` (one
compiled function per rung): the count by status and by final rung, the first pass's time
(it compiles) and a second pass's (steady state); no flights.

    python experiments/fuel_refine_dispersion.py --n 60 [--at-switches] [--scheme LGR|LGL] [--batch]
    python experiments/fuel_refine_dispersion.py --constrained --n 6 [--at-switches]
"""

import argparse
import collections
import sys
import time
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

import jaxlpm as lpm  # noqa: E402
from jaxlpm.batch.refine import fuel_ladder, refine_batch  # noqa: E402
from jaxlpm.solvers import fuel_optimal  # noqa: E402

A = 7000e3


def free(rng):
    o = lpm.KeplerOrbit(a=jnp.asarray(A), e=jnp.asarray(rng.uniform(0.0, 0.5)))
    y = rng.choice([-1.0, 1.0]) * rng.uniform(2000.0, 10000.0)
    xf = jnp.array([rng.uniform(-500, 500), y, rng.uniform(-500, 500), 0.0, 0.0, 0.0])
    return lpm.FuelOptimalTransfer(o, jnp.zeros(6), xf,
                                   jnp.asarray(rng.uniform(0.5, 1.5) * float(o.period)),
                                   jnp.asarray(rng.uniform(0.1, 0.5)), jnp.asarray(50.0),
                                   jnp.asarray(1000.0))


def constrained(rng):
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
    from test_fuel_constrained import flyby
    p = flyby(rng.uniform(1000.0, 1800.0))
    o = p.orbit.replace(e=jnp.asarray(rng.uniform(0.0, 0.15)))
    return p.replace(orbit=o, duration=jnp.asarray(rng.uniform(0.4, 0.6) * float(o.period)))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--n", type=int, default=60)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--constrained", action="store_true")
    ap.add_argument("--at-switches", action="store_true", help="breaks at the switches")
    ap.add_argument("--scheme", default=None, choices=("LGR", "LG", "LGL"),
                    help="the segments of the family's ladder (default: its own)")
    ap.add_argument("--batch", action="store_true", help="refine_batch over the members")
    args = ap.parse_args()
    if args.at_switches:
        fuel_optimal.COAST_RATIO = 0.0
    rng = np.random.default_rng(args.seed)
    make = constrained if args.constrained else free
    ladder = fuel_optimal.CONSTRAINED_LADDER if args.constrained else fuel_optimal.LADDER
    ladder = lpm.MeshLadder(ladder.rungs, args.scheme or ladder.scheme)
    if args.batch:
        return batch(make, rng, ladder, args.n)
    counts = collections.Counter()
    worst = 0.0
    start = time.perf_counter()
    for i in range(args.n):
        problem = make(rng)
        t = time.perf_counter()
        sol = lpm.solve(problem, ladder, throw=False)
        status = lpm.Status(int(sol.status)).name
        counts[status] += 1
        miss = np.asarray(lpm.verify.fly(sol, model="linear").plan_error)
        if status == "SUCCESS":
            worst = max(worst, float(miss[0]))
        print(f"{i}: {status}, {int(sol.stats['mesh_passes'])} meshes, delta-v "
              f"{float(sol.cost):.6f} m/s, thrust excess {float(sol.stats['path_violation']):.1e}"
              f" m/s, flown from the plan {miss[0]:.1e} m {miss[1]:.1e} m/s "
              f"({time.perf_counter() - t:.1f} s)", flush=True)
    print(f"{dict(counts)}; largest flown distance of a SUCCESS member {worst:.2e} m; "
          f"{time.perf_counter() - start:.0f} s")


def batch(make, rng, ladder, n):
    """The members refined together by `refine_batch`, twice (module docstring)."""
    members = [make(rng) for _ in range(n)]
    problems = jax.tree_util.tree_map(lambda *x: jnp.stack(x), *members)
    ladder = fuel_ladder(ladder)          # the single solve's meshes, one rung each
    for label in ("first pass (compiles)", "second pass (steady state)"):
        t = time.perf_counter()
        out = refine_batch(problems, ladder=ladder)
        took = time.perf_counter() - t
        counts = collections.Counter(lpm.Status(int(s)).name for s in out["status"])
        rungs = np.bincount(out["rung"], minlength=len(ladder.rungs))
        print(f"{ladder.scheme} ladder, {label}: {took:.1f} s; {dict(counts)}; members per "
              f"final rung {rungs.tolist()}", flush=True)


if __name__ == "__main__":
    main()
