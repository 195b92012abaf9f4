"""Input checks at the Python boundary (ValueError) and their traced counterparts (status)."""

import dataclasses
import functools
from typing import NamedTuple

import jax
import jax.numpy as jnp
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


def array_module(*trees):
    """NumPy where no leaf of `trees` is a JAX array (or tracer), else jax.numpy: the module
    that `Checked` rules written once compute their flags with, on the host for a
    `Checked.validate` (no program compiled per check and shape) and in the graph for
    `Checked.validity`."""
    leaves = jax.tree_util.tree_leaves(trees)
    return jnp if any(isinstance(x, jax.Array) for x in leaves) else np


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
    Static fields, fields marked metadata tree=True (a tuple of pytrees), arrays and tracers
    are left as they are."""
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        if (not f.metadata.get("static") and not f.metadata.get("tree")
                and isinstance(value, (list, tuple))):
            try:
                arr = np.asarray(value, dtype=np.float64)
            except (TypeError, ValueError) as err:
                raise ValueError(f"{f.name} must be numeric, got {value!r:.80}") from err
            object.__setattr__(obj, f.name, arr)


class Rule(NamedTuple):
    """One input check: the field it is about (a dotted path such as "orbit.e"), its in-graph
    flag (True where the input is allowed) and what is allowed, in words with units."""

    name: str
    ok: object
    allowed: str


class Checked:
    """Input checks written once, for a frozen dataclass of array leaves (a problem, an orbit).

    A class lists its checks once, in `rules()` (values: `Rule`s of in-graph flags) and
    `SHAPES` ({field: shape}: what is known at trace time too; `static_rules()` checks them
    and the static rules of nested `Checked` fields, and a class with more static fields
    extends it), and names a harmless valid instance in `harmless()`. From them:
      validate()      concrete input: the static rules, then ValueError naming the first
                      `Rule` that fails, its value and what is allowed (the rules evaluated
                      by NumPy on a host copy: `array_module`);
      validity()      traced input: the conjunction of the rules' flags (status INVALID_INPUT
                      where False);
      sanitized(ok)   every leaf replaced by the harmless instance's where ok is False, so an
                      invalid member of a batch computes finite numbers (then zeroed).
    `check()` does what fits the input: everything when concrete, the static rules when traced.
    """

    def rules(self) -> list:
        raise NotImplementedError

    SHAPES: dict = {}

    def static_rules(self) -> None:
        """Raise ValueError for what is wrong at trace time too: the shapes and real types of
        the fields in `SHAPES`, then the static rules of nested `Checked` fields."""
        for name, shape in self.SHAPES.items():
            check_shape(name, getattr(self, name), shape)
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if isinstance(value, Checked):
                value.static_rules()

    def harmless(self):
        raise NotImplementedError

    def validate(self) -> None:
        self.static_rules()
        host = jax.tree_util.tree_map(np.asarray, self)     # the rules computed by NumPy
        for rule in host.rules():
            if not bool(rule.ok):
                raise ValueError(f"{rule.name} must be {rule.allowed}, got "
                                 f"{_field(self, rule.name)}")

    def validity(self):
        flags = [jnp.all(rule.ok) for rule in self.rules()]
        return functools.reduce(jnp.logical_and, flags, jnp.array(True))

    def sanitized(self, valid):
        safe = self.harmless()
        return jax.tree_util.tree_map(
            lambda x, s: jnp.where(valid, x, jnp.asarray(s, jnp.result_type(x))), self, safe)

    def check(self) -> None:
        if is_concrete(self):
            self.validate()
        else:
            self.static_rules()


def _field(obj, dotted: str):
    """The value a rule's name points to: "orbit.e", "constraints[1].range"."""
    for part in dotted.split("."):
        name, _, index = part.partition("[")
        obj = getattr(obj, name, None)
        if index and isinstance(obj, (tuple, list)):
            obj = obj[int(index.rstrip("]"))]
    return obj


def check_scalars(owner: str, obj, names) -> None:
    """ValueError unless each named field of obj is a real scalar."""
    for name in names:
        check_shape(f"{owner}{name}", getattr(obj, name), ())
