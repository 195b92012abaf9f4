"""Test session set-up: float64 everywhere, a persistent compilation cache shared with the
subprocess tests (JAX's, and jaxlpm's executables under it: `jaxlpm.compilation`), and XLA's
CPU backend at LLVM optimisation level 0 with the classic loop emitters for the tests' own
jitted functions too (jaxlpm's "fast" profile): compile time dominates this suite, and level 0
cut tests/test_lq.py from 152 s to 120 s cold on the 2-core VM. Either option set in
XLA_FLAGS is kept. The pytest-xdist workers
(pyproject's addopts) share the caches; an entry being written by another worker is a miss."""

import os
from pathlib import Path

for _flag in ("xla_backend_optimization_level=0", "xla_cpu_use_fusion_emitters=false"):
    if _flag.split("=")[0] not in os.environ.get("XLA_FLAGS", ""):
        os.environ["XLA_FLAGS"] = f"{os.environ.get('XLA_FLAGS', '')} --{_flag}".strip()

import jax  # noqa: E402  (after XLA_FLAGS: the backend reads it when it starts)

CACHE_DIR = str(Path(__file__).resolve().parent.parent / ".jax_cache")
os.environ.setdefault("JAXLPM_CACHE_DIR", CACHE_DIR)
jax.config.update("jax_enable_x64", True)
jax.config.update("jax_compilation_cache_dir", CACHE_DIR)
jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.5)


import gc  # noqa: E402

import pytest  # noqa: E402

import jaxlpm as lpm  # noqa: E402


@pytest.fixture(autouse=True, scope="module")
def _release_compiled_programs():
    """Drop JAX's in-memory caches after each test module, so the compiled programs it no
    longer needs are freed (the persistent cache above makes a later recompile a load). XLA:CPU
    maps each executable's code into its own memory regions; the whole suite in one process
    passed vm.max_map_count (65530 regions: 32 000 were in use at 42 % of the suite) and the
    next compile crashed with a segmentation fault."""
    yield
    jax.clear_caches()
    lpm.compilation.clear()
    gc.collect()


# The files that take longest (`python -m pytest --durations=0`, summed per file: 70-143 s
# each on the 2-core VM, 2026-12-08), handed to the parallel workers first, so that the
# workers finish together instead of one running a long file alone at the end (longest
# first).
SLOW_FILES_FIRST = ("test_safety.py", "test_meshes.py", "test_min_time_eccentric.py",
                    "test_sweep_refine.py", "test_accuracy.py", "test_newton.py",
                    "test_lg_segments.py", "test_api.py", "test_fuel_constrained.py",
                    "test_tan2011.py", "test_min_time.py", "test_refine_batch.py")


def pytest_collection_modifyitems(items):
    rank = {name: i for i, name in enumerate(SLOW_FILES_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(SLOW_FILES_FIRST)))


UNRESOLVED_OK = lpm.Tolerance(position=1e12, velocity=1e9, path=1e9)


@pytest.fixture(scope="module")
def loose_accuracy():
    """For the modules that test a solver's algebra, validation or batching on grids chosen
    small for speed, not to resolve the transfer (issue 19 made such solutions INACCURATE):
    `solve`'s default tolerance there accepts any estimate. The estimate and the INACCURATE
    status themselves are tested in tests/test_accuracy.py."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr("jaxlpm.solvers.api.DEFAULT_TOLERANCE", UNRESOLVED_OK)
        yield
