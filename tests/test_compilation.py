"""jaxlpm.compilation: the executable cache and the compile profiles (issue 21).

The cache must give the same numbers as a fresh compile, skip tracing when it hits, survive
an unreadable entry, stay out of the way under a user's jit/vmap, and be off when asked; the
integrators must trace without host callbacks (a program with one cannot be cached)."""

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxlpm as lpm
from jaxlpm import compilation
from jaxlpm.cases import mei2010
from jaxlpm.dynamics.propagation import COAST, solve_ode
from jaxlpm.status import Status

ROOT = Path(__file__).resolve().parent.parent

# One small law solve (lgl(9): its QR runs through LAPACK, which a loaded executable must
# find bound) per process; with FORBID_TRACE the function the cache traces raises, so the
# process can only succeed by loading the executable the first process wrote.
SCRIPT = textwrap.dedent("""
    import sys
    import jax
    jax.config.update("jax_enable_x64", True)
    if len(sys.argv) > 2:
        jax.config.update("jax_compilation_cache_dir", sys.argv[2])
        jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
    import jaxlpm as lpm
    from jaxlpm.cases import mei2010
    if sys.argv[1] == "forbid-trace":
        def traced(*args, **kwargs):
            raise AssertionError("traced although the executable is cached")
        lpm.compilation.Compiled._adapter = traced
    s = lpm.solve(mei2010.problem(), lpm.lgl(9), method="kkt", throw=False)
    print(repr(float(s.cost)), int(s.status), repr(float(s.states(1000.0)[0])))
""")


def _run(cache, mode, jax_cache=None):
    """The script in a fresh process with this executable cache (and JAX's persistent
    compilation cache in `jax_cache`, when given)."""
    env = dict(os.environ, JAXLPM_CACHE_DIR=str(cache), PYTHONPATH=str(ROOT))
    args = [] if jax_cache is None else [str(jax_cache)]
    out = subprocess.run([sys.executable, "-c", SCRIPT, mode, *args], env=env,
                         capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-3000:]
    return out.stdout.split()


def test_executable_cached_across_processes(tmp_path):
    first = _run(tmp_path, "compile")
    files = list((tmp_path / "executables").glob("*.bin"))
    assert files, "nothing was written to the executable cache"
    second = _run(tmp_path, "forbid-trace")
    assert second == first            # the same executable: bit-identical numbers


def test_program_in_jax_cache_is_compiled_afresh_for_the_disk(tmp_path):
    """An executable JAX's persistent cache supplied is not what is written to this cache:
    written, it failed when loaded in the next process ("Function and_and_fusion not found",
    `jaxlpm.compilation`); left unwritten, every later process traced the program again. Here
    the first process fills both caches; twice (as after two upgrades of jaxlpm: the fresh
    compile must not have entered JAX's cache either), this one is emptied and the next
    process (the program in JAX's cache) must write a fresh compile; a last one must load it
    without tracing and give the same numbers."""
    ours, theirs = tmp_path / "jaxlpm", tmp_path / "jax"
    first = _run(ours, "compile", theirs)
    entries = list((ours / "executables").glob("*.bin"))
    assert entries and list(theirs.iterdir())
    for _ in range(2):
        for entry in (ours / "executables").glob("*.bin"):
            entry.unlink()
        assert _run(ours, "compile", theirs) == first
        assert len(list((ours / "executables").glob("*.bin"))) == len(entries)
    assert _run(ours, "forbid-trace", theirs) == first


def test_unreadable_entry_is_a_miss(tmp_path):
    bad = tmp_path / "garbage.bin"
    bad.write_bytes(b"not an executable")
    assert compilation._read(bad) is None


@pytest.fixture(scope="module")
def law_problem():
    return mei2010.problem()


def test_traced_call_inlines_into_the_callers_program(law_problem):
    grid = lpm.lgl(9)
    concrete = lpm.solve(law_problem, grid, method="kkt", throw=False)
    jitted = jax.jit(lambda p: lpm.solve(p, grid, method="kkt", throw=False).cost)(law_problem)
    batch = jax.tree_util.tree_map(lambda x: jnp.stack([x, x]), law_problem)
    mapped = jax.vmap(lambda p: lpm.solve(p, grid, method="kkt", throw=False).cost)(batch)
    # the same law under XLA's default options instead of the fast profile: the same
    # operations, reassociated by the optimiser at most (round-off of a 1e-4 cost)
    np.testing.assert_allclose(jitted, concrete.cost, rtol=1e-11)
    np.testing.assert_allclose(mapped, concrete.cost, rtol=1e-11)


def test_cache_off_and_profiles(monkeypatch):
    monkeypatch.setenv("JAXLPM_CACHE_DIR", "")
    assert compilation.cache_dir() is None
    monkeypatch.setenv("JAXLPM_CACHE_DIR", "/some/where")
    assert compilation.cache_dir() == Path("/some/where") / "executables"
    with pytest.raises(ValueError, match="profile must be one of"):
        compilation.set_profile("turbo")
    before = compilation.profile()
    try:
        compilation.set_profile("optimized")
        assert compilation.compiler_options() == {}
    finally:
        compilation.set_profile(before)


def test_integrators_trace_without_host_callbacks():
    """equinox's runtime checks inside diffrax are traced as NaN, not as a host callback
    (which would keep the flights and the J2 transfers out of every cache) ..."""
    ts = jnp.linspace(0.0, 1.0, 5)
    jaxpr = jax.make_jaxpr(lambda y0: solve_ode(lambda t, y: -y, y0, 0.0, 1.0, ts, COAST))(
        jnp.ones(2))
    assert "callback" not in str(jaxpr)


def test_failed_runtime_check_is_a_status_not_an_exception():
    """... and a check that fails (save times out of order) still fails: NONFINITE."""
    ys, status = jax.jit(lambda ts: solve_ode(lambda t, y: -y, jnp.ones(2), 0.0, 1.0, ts,
                                              COAST))(
        jnp.array([0.0, 0.8, 0.4, 1.0]))
    assert int(status) == Status.NONFINITE


@compilation.compiled
def _scaled_sum(x, y):
    return jnp.sum(x) * y, x * 2.0


def test_prefetch_compiles_what_the_run_needs(monkeypatch):
    """A dry run compiles every program the run will call (three shapes; each second call,
    on outputs of the first, has its signature: weak and strong types are one key),
    concurrently; the real run then compiles
    nothing and gives the numbers of an uncached run. A dry run that fails on its zeros ends
    early and the real run compiles the rest."""
    monkeypatch.setenv("JAXLPM_CACHE_DIR", "")            # memory only: nothing from disk

    def run():
        out = []
        for n in (3, 4, 5):
            total, doubled = _scaled_sum(jnp.arange(float(n)), 2.0)
            out.append(_scaled_sum(doubled, total)[0])
        return out

    compilation.clear()
    expected = [float(v) for v in run()]
    compilation.clear()
    lines = []
    assert compilation.prefetch(run, lines.append) == 3
    assert sum(line.startswith("compiled ") for line in lines) == 3
    before = len(compilation.events)
    assert [float(v) for v in run()] == expected
    assert len(compilation.events) == before                 # nothing compiled or loaded

    def fails_on_zeros():
        total, _ = _scaled_sum(jnp.arange(3.0), 2.0)
        if float(total) == 0.0:                               # a value the dry run lacks
            raise RuntimeError("zero")
        _scaled_sum(jnp.arange(7.0), 1.0)

    compilation.clear()
    lines = []
    assert compilation.prefetch(fails_on_zeros, lines.append) == 1
    assert any("stopped early" in line for line in lines)
    fails_on_zeros()                                         # compiles the second program
    compilation.clear()


def test_pipelined_solve_compiles_its_stages_once_and_matches_one_program(monkeypatch):
    """A first Newton-KKT solve compiles its three stages by one prefetch dry run
    (`compilation.pipelined`), a second solve of the same signature neither dry-runs nor
    compiles, and the stages give the transfer of the whole solver compiled as one program
    (`jax.jit(newton_transfer)`)."""
    from jaxlpm.solution.accuracy import Judge
    from jaxlpm.solvers.transfer import newton_transfer

    monkeypatch.setenv("JAXLPM_CACHE_DIR", "")            # memory only: nothing from disk
    dry_runs = []
    prefetch = compilation.prefetch
    monkeypatch.setattr(compilation, "prefetch",
                        lambda run, **kw: dry_runs.append(prefetch(run, **kw)))
    problem, grid = mei2010.problem().replace(model="two-body"), lpm.lgl(17)
    compilation.clear()
    before = len(compilation.events)
    staged = lpm.solve(problem, grid, method="newton", throw=False)
    names = sorted(e["name"].rsplit(".", 1)[-1] for e in compilation.events[before:])
    assert names == ["transfer_setup", "transfer_solution", "transfer_solve"]
    assert dry_runs == [3]
    lpm.solve(problem, grid, method="newton", throw=False)
    assert dry_runs == [3] and len(compilation.events) == before + 3
    whole = jax.jit(newton_transfer)(problem, grid)
    assert int(whole.status) == Status.SUCCESS
    assert int(staged.status) == int(Judge()(whole).status)   # solve's verdict, as its own
    # the same iterations in other programs: XLA fuses them differently, so only round-off
    # separates the two (the Newton-KKT tolerance is 1e-10 in the solver's units)
    np.testing.assert_allclose(float(staged.cost), float(whole.cost), rtol=1e-9)
    u = np.asarray(whole.node_controls)
    np.testing.assert_allclose(staged.node_controls, u, rtol=0,
                               atol=1e-9 * np.max(np.abs(u)))
    compilation.clear()


def test_a_dry_run_answers_only_its_own_thread(monkeypatch):
    """Every first solve may dry-run (`pipelined`): another thread's calls meanwhile run as
    usual, with their real values, not the dry run's zeros."""
    import threading

    monkeypatch.setenv("JAXLPM_CACHE_DIR", "")
    inside, leave = threading.Event(), threading.Event()

    def run():
        _scaled_sum(jnp.arange(3.0), 2.0)
        inside.set()
        leave.wait(60)

    worker = threading.Thread(target=compilation.prefetch, args=(run,))
    worker.start()
    assert inside.wait(60)
    total, _ = _scaled_sum(jnp.arange(3.0), 2.0)         # this thread, during the dry run
    leave.set()
    worker.join()
    assert float(total) == 6.0                           # (0 + 1 + 2) * 2


def test_a_non_array_argument_is_static_or_a_clear_error():
    """A compiled function's settings object (an `Integrator`) is not an array: in
    static_argnames it keys the executable; left dynamic, the call says which argument kind
    needs static_argnames (it once stopped `jaxlpm reproduce tan2011` with JAX's bare
    "not a valid JAX type")."""
    from jaxlpm.dynamics.propagation import propagate

    state = jnp.array([7.0e6, 0.0, 0.0, 0.0, 7.5e3, 0.0])
    with pytest.raises(TypeError, match="static_argnames"):
        compilation.compiled(propagate)(state, 60.0)
    end, ok = compilation.compiled(propagate, static_argnames="integrator")(state, 60.0)
    direct, _ = propagate(state, 60.0)
    assert bool(ok)
    # the same integration, compiled apart from the eager one: round-off apart
    np.testing.assert_allclose(end, direct, rtol=1e-12)
