"""CPU runtime settings jaxlpm needs, applied at import, before JAX starts its CPU backend.

1. jaxlib 0.10's concurrency-optimised XLA:CPU scheduler can deadlock when two batched LAPACK
   calls (QR, SVD) of one jitted, vmapped function run at once: `jit(vmap(kkt_law))` over 256
   problems hung with both worker threads idle, and runs in about 0.9 s per call with the
   scheduler off (BENCHMARKS.md, "Environment problems"). The flag only acts if it is in
   XLA_FLAGS before the backend starts; if JAX already runs without it, a warning says so.
2. jaxlib's CPU LAPACK kernels run on scipy's OpenBLAS, whose own thread pool contends with
   XLA's on small machines (a batched QR took 0.6-8.7 s instead of 0.05 s). One OpenBLAS
   thread is set unless the user chose a value or scipy (which loads OpenBLAS) is already
   imported.
A value the user set in the environment is always respected.
"""

import os
import sys
import warnings

SCHEDULER_FLAG = "--xla_cpu_enable_concurrency_optimized_scheduler=false"
_SCHEDULER = "xla_cpu_enable_concurrency_optimized_scheduler"


def apply() -> None:
    if "scipy" not in sys.modules:
        os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    flags = os.environ.get("XLA_FLAGS", "")
    if _SCHEDULER in flags:
        return
    from jax._src import xla_bridge

    if xla_bridge.backends_are_initialized():
        warnings.warn(
            f"JAX's backend started before jaxlpm was imported, without {SCHEDULER_FLAG}: "
            f"batched (vmapped) KKT solves may deadlock on CPU. Import jaxlpm first or set "
            f"XLA_FLAGS={SCHEDULER_FLAG}.", RuntimeWarning, stacklevel=3)
        return
    os.environ["XLA_FLAGS"] = f"{flags} {SCHEDULER_FLAG}".strip()
