"""CPU runtime settings jaxlpm needs, applied at import, before JAX starts its CPU backend.

1. Two of jaxlib 0.10's batched CPU LAPACK calls running at once deadlock XLA's 2-thread
   intra-op pool (`jaxlpm.linalg.sequential_when_batched`). XLA's concurrency-optimised
   scheduler runs independent ones at once: a vmapped value-and-gradient of the KKT law (as
   it was, batched QR and SVD) hung on the first call at every batch size tried (4 to 128,
   lgl(65)). With the scheduler off it hung rarely (1 of ~800 calls, 128 members): a
   mitigation, not a fix. The library's vmapped paths now run LAPACK member by member
   (`member_by_member`); the flag stays for those that do not yet, and for user code.
   It only acts if it is in XLA_FLAGS before the backend starts; if JAX already runs without
   it, a warning says so.
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
            f"batched (vmapped) LAPACK calls may deadlock on CPU. Import jaxlpm first or set "
            f"XLA_FLAGS={SCHEDULER_FLAG}.", RuntimeWarning, stacklevel=3)
        return
    os.environ["XLA_FLAGS"] = f"{flags} {SCHEDULER_FLAG}".strip()
