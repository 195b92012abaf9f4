"""Test session set-up: float64 everywhere, a persistent compilation cache shared with the
subprocess tests, and XLA's CPU backend at LLVM optimisation level 0 (compile time dominates
this suite: level 0 compiles about 20 % faster; the programs' results differ from level 3's
in the last bits only, far inside every tolerance here). A level set in XLA_FLAGS is kept."""

import os
from pathlib import Path

if "xla_backend_optimization_level" not in os.environ.get("XLA_FLAGS", ""):
    os.environ["XLA_FLAGS"] = (os.environ.get("XLA_FLAGS", "")
                               + " --xla_backend_optimization_level=0").strip()

import jax  # noqa: E402  (after XLA_FLAGS: the backend reads it when it starts)

CACHE_DIR = str(Path(__file__).resolve().parent.parent / ".jax_cache")
os.environ.setdefault("JAXLPM_CACHE_DIR", CACHE_DIR)
jax.config.update("jax_enable_x64", True)
jax.config.update("jax_compilation_cache_dir", CACHE_DIR)
jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.5)
