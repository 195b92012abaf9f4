"""Test session set-up: float64 everywhere, and a persistent compilation cache shared with the
subprocess tests (compile time dominates this suite)."""

import os
from pathlib import Path

import jax

CACHE_DIR = str(Path(__file__).resolve().parent.parent / ".jax_cache")
os.environ.setdefault("JAXLPM_CACHE_DIR", CACHE_DIR)
jax.config.update("jax_enable_x64", True)
jax.config.update("jax_compilation_cache_dir", CACHE_DIR)
jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.5)
