"""Input checks at the Python boundary (ValueError) and their traced counterparts (status)."""

import dataclasses

import jax
import numpy as np


def require_x64() -> None:
    """Raise ValueError unless JAX runs in float64 (jaxlpm refuses float32)."""
    if not jax.config.jax_enable_x64:
        raise ValueError(
            "jaxlpm needs float64: call jax.config.update('jax_enable_x64', True) "
            "(or set JAX_ENABLE_X64=1) before creating arrays"
        )


def is_concrete(*xs) -> bool:
    """True when every leaf is a concrete (non-traced) value that can be checked on the host."""
    return not any(isinstance(leaf, jax.core.Tracer) for leaf in jax.tree_util.tree_leaves(xs))


def real_array(name: str, value):
    """`value` as a float64 NumPy array (a tracer is returned as it is, its dtype checked);
    ValueError naming `name` unless it is real numbers (ints or floats, not bool, complex,
    strings or objects)."""
    dtype = value.dtype if isinstance(value, jax.core.Tracer) else None
    if dtype is None:
        try:
            arr = np.asarray(value)
        except (TypeError, ValueError):
            arr = np.asarray(None)
        dtype = arr.dtype
    if dtype.kind not in "iuf":
        raise ValueError(f"{name} must be real numbers (int or float), got {value!r:.80}")
    return value if isinstance(value, jax.core.Tracer) else arr.astype(np.float64)


def check_finite(name: str, value) -> np.ndarray:
    arr = real_array(name, value)
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got {arr!r}")
    return arr


def check_shape(name: str, value, shape: tuple) -> None:
    got = np.shape(real_array(name, value))
    if got != shape:
        raise ValueError(f"{name} must have shape {shape}, got {got}")


def coerce_sequences(obj) -> None:
    """In a frozen dataclass's __post_init__: turn its array fields given as Python lists or
    tuples into float64 arrays (a list would otherwise become a pytree of scalar leaves).
    Static fields, arrays and tracers are left as they are."""
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        if not f.metadata.get("static") and isinstance(value, (list, tuple)):
            try:
                arr = np.asarray(value, dtype=np.float64)
            except (TypeError, ValueError) as err:
                raise ValueError(f"{f.name} must be numeric, got {value!r:.80}") from err
            object.__setattr__(obj, f.name, arr)
