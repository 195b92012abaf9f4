"""Timing helpers shared by the benchmark scripts (compile and steady state measured apart)."""

import multiprocessing
import os
import platform
import statistics
import time

import jax
import numpy as np

from jaxlpm import compilation

# Steady-state benchmarks compile the library's solvers with XLA's default options, as a user
# who solves many problems one by one would (`jaxlpm.compilation`, "optimized"); the cold
# start is bench_compile.py's job.
compilation.set_profile("optimized")


def block(tree):
    return jax.block_until_ready(tree)


def member(tree, i):
    """Member i of a batched pytree (leading axis: members)."""
    return jax.tree_util.tree_map(lambda x: x[i], tree)


def timed(fn, *, min_repeats=5, max_repeats=200, budget_s=2.0):
    """Median (and min, count) wall and process-CPU time of fn() over repeats; fn must block
    on its result."""
    times, cpu = [], []
    start = time.perf_counter()
    while len(times) < max_repeats:
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
        if len(times) >= min_repeats and time.perf_counter() - start > budget_s:
            break
    return dict(median_s=statistics.median(times), min_s=min(times), repeats=len(times),
                cpu_median_s=statistics.median(cpu), all_s=times if len(times) <= 10 else None)


def cold_compile(fn, *args, repeats=2, compiler_options=None):
    """Lower + compile times of jax.jit(fn) with the in-memory caches cleared (median), wall
    and process CPU time (the latter barely depends on other processes' load)."""
    lows, comps, cpus = [], [], []
    compiled = None
    for _ in range(repeats):
        jax.clear_caches()
        t0, c0 = time.perf_counter(), time.process_time()
        lowered = jax.jit(fn).lower(*args)
        t1 = time.perf_counter()
        compiled = lowered.compile(compiler_options=compiler_options)
        t2 = time.perf_counter()
        cpus.append(time.process_time() - c0)
        lows.append(t1 - t0)
        comps.append(t2 - t1)
    tot = [a + b for a, b in zip(lows, comps)]
    return compiled, dict(lower_s=statistics.median(lows), compile_s=statistics.median(comps),
                          total_s=statistics.median(tot), cpu_s=statistics.median(cpus),
                          repeats=repeats, compiler_options=compiler_options,
                          loadavg=os.getloadavg())


def machine_info(**versions):
    """CPU, platform, library versions (plus `versions`), CPU runtime settings, load."""
    model = "unknown"
    try:
        with open("/proc/cpuinfo") as fh:
            model = next(line.split(":", 1)[1].strip() for line in fh
                         if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    return dict(cpu_model=model, nproc=len(os.sched_getaffinity(0)), cpu_count=os.cpu_count(),
                platform=platform.platform(), python=platform.python_version(),
                jax=jax.__version__, jax_backend=jax.default_backend(), numpy=np.__version__,
                **versions, xla_flags=os.environ.get("XLA_FLAGS", ""),
                openblas_num_threads=os.environ.get("OPENBLAS_NUM_THREADS", ""),
                loadavg_start=os.getloadavg())


def batched_solves(problems, mesh, width):
    """Our side of a batch benchmark: `jaxlpm.solve` of every member on `mesh` in one jitted
    `lax.map` (`map_in_groups`, `width` members vmapped together). Returns (solutions, first
    call s, `timed` steady state, status counts by name)."""
    import jaxlpm as lpm
    from jaxlpm.mapping import map_in_groups

    solve = jax.jit(lambda ps: map_in_groups(lambda p: lpm.solve(p, mesh, throw=False), ps,
                                             width))
    t0 = time.perf_counter()
    sols = block(solve(problems))
    first = time.perf_counter() - t0
    steady = timed(lambda: block(solve(problems)), min_repeats=3, budget_s=10.0)
    values, counts = np.unique(np.asarray(sols.status), return_counts=True)
    return sols, first, steady, {lpm.Status(int(v)).name: int(c) for v, c in zip(values, counts)}


def peer_pool(worker, shares, members):
    """The peer's side: worker(share) -> (build s, [record per problem]) in one spawned
    process per share, problem j of share i being member i + j len(shares). Returns (builds,
    records in member order, wall s, status counts)."""
    procs = len(shares)
    t0 = time.perf_counter()
    with multiprocessing.get_context("spawn").Pool(procs) as pool:
        results = pool.map(worker, shares)
    wall = time.perf_counter() - t0
    records = [None] * members
    for i, (_, out) in enumerate(results):
        for j, r in enumerate(out):
            records[i + j * procs] = r
    statuses = {}
    for r in records:
        statuses[r["status"]] = statuses.get(r["status"], 0) + 1
    return [b for b, _ in results], records, wall, statuses


def eccentric_ends(key_e, key_r, size):
    """(orbit, xf) of the eccentric dispersions of bench_fuel.py and bench_min_time.py: chief
    perigee radius 7000 km, e uniform in [0, 0.5] (key_e), equatorial, starting at perigee;
    the end at rest at a point uniform in a box of +-4 km (radial, along-track) and +-1 km
    (normal) (key_r), LVLH m, m/s."""
    import jax.numpy as jnp
    import jaxlpm as lpm

    e = jax.random.uniform(key_e, (size,), maxval=0.5)
    zero = jnp.zeros(size)
    orbit = lpm.KeplerOrbit(a=7000e3 / (1.0 - e), e=e, i=zero, raan=zero, argp=zero, f0=zero,
                            mu=jnp.full(size, lpm.constants.MU_EARTH))
    r = jax.random.uniform(key_r, (size, 3), minval=-1.0, maxval=1.0) * jnp.array(
        [4e3, 4e3, 1e3])
    return orbit, jnp.concatenate([r, jnp.zeros((size, 3))], axis=1)


def dispersion_arguments(parser, out):
    """The options bench_fuel.py and bench_min_time.py share: --members, --segments, --points
    (the uniform LGR mesh), --seed, --width (`batched_solves`) and --out (default `out`)."""
    parser.add_argument("--members", type=int, default=256)
    parser.add_argument("--segments", type=int, default=24)
    parser.add_argument("--points", type=int, default=8)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--width", type=int, default=1,
                        help="members vmapped together inside the batch's lax.map")
    parser.add_argument("--out", default=out)
