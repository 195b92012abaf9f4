"""A jaxlpm result as a JSON structure plus NumPy arrays, and back, without pickle (what
`jaxlpm.io.save` writes and `load` reads).

`encode(obj)` returns (node, arrays): `node` is JSON, `arrays` maps names to the NumPy arrays
of obj's array leaves. A node is
  null, true/false, an int, a finite float, a str    that Python value
  {"float": "inf"}                                    a non-finite float ("inf", "-inf", "nan")
  {"array": name, "type": t, "weak": w}               arrays[name] as a jax.Array (t "jax",
                                                      weakly typed if w), a NumPy array
                                                      ("numpy") or a NumPy scalar ("scalar")
  {"tuple": [...]}, {"list": [...]}                   a tuple, a list
  {"dict": [[key, node], ...]}                        a dict (str, int or float keys, in
                                                      order)
  {"path": "..."}                                     a pathlib.Path
  {"grid": [scheme, n]}                               a collocation `Grid` (`make_grid`)
  {"class": "jaxlpm.mod.Name", "fields": {...}}       a jaxlpm dataclass, field by field
  {"class": "jaxlpm.mod.Name", "items": [...]}        a jaxlpm NamedTuple
`decode(node, arrays)` rebuilds the object: every array bit for bit with its dtype and kind
(weak type included), dataclasses by setting their fields without calling __init__ (nothing
is converted or checked again), so a rebuilt `Solution` has the saved pytree structure and
leaves and evaluates bit-identically. The allow-list: only classes defined in jaxlpm
(dataclasses and NamedTuples, found by module and name) are rebuilt, so a file cannot name
other code.
"""

import dataclasses
import importlib
import math
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from ..collocation import Grid, make_grid

PACKAGE = "jaxlpm"


def _is_namedtuple(x) -> bool:
    return isinstance(x, tuple) and hasattr(type(x), "_fields")


def _allowed_class(path: str, where: str) -> type:
    """The jaxlpm dataclass or NamedTuple named `path` ("jaxlpm.module.Name"); ValueError
    for anything else."""
    module, _, name = path.rpartition(".")
    cls = None
    if module == PACKAGE or module.startswith(PACKAGE + "."):
        try:
            cls = getattr(importlib.import_module(module), name, None)
        except ImportError:
            pass
    if not (isinstance(cls, type) and (dataclasses.is_dataclass(cls)
                                       or (issubclass(cls, tuple) and hasattr(cls, "_fields")))):
        raise ValueError(f"{where}: {path!r} is not a jaxlpm dataclass or NamedTuple (only "
                         f"those are saved and loaded)")
    return cls


def _class_path(x, where: str) -> str:
    cls = type(x)
    path = f"{cls.__module__}.{cls.__qualname__}"
    if _allowed_class(path, where) is not cls:
        raise ValueError(f"{where}: {path!r} is not a jaxlpm dataclass or NamedTuple (only "
                         f"those are saved and loaded)")
    return path


class _Encoder:
    def __init__(self):
        self.arrays = {}

    def array(self, x, kind: str, where: str) -> dict:
        try:
            arr = np.asarray(x)
        except (TypeError, ValueError) as err:
            raise ValueError(f"{where}: cannot save a {type(x).__name__} ({err})") from None
        if arr.dtype.hasobject:
            raise ValueError(f"{where}: cannot save an array of Python objects")
        name = f"a{len(self.arrays):05d}"
        self.arrays[name] = arr
        return {"array": name, "type": kind, "weak": bool(getattr(x, "weak_type", False))}

    def node(self, x, where: str):
        if isinstance(x, jax.core.Tracer):
            raise ValueError(f"{where}: cannot save a traced value (save outside jit/vmap/grad)")
        if x is None or type(x) in (bool, int, str):
            return x
        if type(x) is float:
            return x if math.isfinite(x) else {"float": repr(x)}
        if isinstance(x, jax.Array):
            return self.array(x, "jax", where)
        if isinstance(x, np.ndarray):
            return self.array(x, "numpy", where)
        if isinstance(x, np.generic):
            return self.array(x, "scalar", where)
        if isinstance(x, Path):
            return {"path": str(x)}
        if isinstance(x, Grid):
            return {"grid": [x.scheme, x.n]}
        if _is_namedtuple(x):
            return {"class": _class_path(x, where),
                    "items": [self.node(v, f"{where}.{k}") for k, v in zip(x._fields, x)]}
        if isinstance(x, (tuple, list)):
            kind = "tuple" if isinstance(x, tuple) else "list"
            return {kind: [self.node(v, f"{where}[{i}]") for i, v in enumerate(x)]}
        if isinstance(x, dict):
            for key in x:
                if type(key) not in (str, int, float):
                    raise ValueError(f"{where}: dict keys must be str, int or float, got "
                                     f"{key!r}")
            return {"dict": [[self.node(k, where), self.node(v, f"{where}[{k!r}]")]
                             for k, v in x.items()]}
        if dataclasses.is_dataclass(x) and not isinstance(x, type):
            return {"class": _class_path(x, where),
                    "fields": {f.name: self.node(getattr(x, f.name), f"{where}.{f.name}")
                               for f in dataclasses.fields(x)}}
        raise ValueError(f"{where}: cannot save a {type(x).__module__}.{type(x).__qualname__} "
                         f"(saved: jaxlpm dataclasses and NamedTuples, arrays, dicts, tuples, "
                         f"lists, str, numbers, None, paths)")


def encode(obj, where: str = "result") -> tuple:
    """(JSON node, {name: NumPy array}) of obj (module docstring); ValueError naming the
    first part that cannot be saved."""
    encoder = _Encoder()
    node = encoder.node(obj, where)
    return node, encoder.arrays


def _jax_array(arr: np.ndarray, weak: bool):
    """arr as a jax.Array, weakly typed if `weak` (a Python-scalar dtype: the array is set into
    a weakly typed one of zeros, which keeps its weak type)."""
    if weak:
        out = jnp.full(arr.shape, arr.dtype.type(0).item()).at[...].set(arr)
        if out.dtype == arr.dtype:
            return out
    return jnp.asarray(arr)


def _array(node: dict, arrays: dict, where: str):
    if node["array"] not in arrays:
        raise ValueError(f"{where}: the archive lacks array {node['array']!r}")
    arr = arrays[node["array"]]
    kind = node.get("type")
    if kind == "jax":
        return _jax_array(arr, bool(node.get("weak")))
    if kind == "numpy":
        return arr
    if kind == "scalar":
        return arr[()]
    raise ValueError(f"{where}: unknown array type {kind!r}")


def _dataclass(cls, fields: dict, arrays: dict, where: str):
    names = [f.name for f in dataclasses.fields(cls)]
    if sorted(names) != sorted(fields):
        raise ValueError(f"{where}: the archive's {cls.__name__} has fields {sorted(fields)}, "
                         f"this jaxlpm's has {sorted(names)}")
    obj = cls.__new__(cls)
    for name in names:
        object.__setattr__(obj, name, decode(fields[name], arrays, f"{where}.{name}"))
    return obj


def decode(node, arrays: dict, where: str = "result"):
    """The object `encode` gave (node, arrays) for; ValueError for a malformed node or a class
    outside the allow-list (module docstring)."""
    if node is None or isinstance(node, (bool, int, float, str)):
        return node
    if isinstance(node, dict):
        if "array" in node:
            return _array(node, arrays, where)
        if "float" in node:
            return float(node["float"])
        if "tuple" in node:
            return tuple(decode(v, arrays, f"{where}[{i}]") for i, v in enumerate(node["tuple"]))
        if "list" in node:
            return [decode(v, arrays, f"{where}[{i}]") for i, v in enumerate(node["list"])]
        if "dict" in node:
            return {decode(k, arrays, where): decode(v, arrays, f"{where}[{k!r}]")
                    for k, v in node["dict"]}
        if "path" in node:
            return Path(node["path"])
        if "grid" in node:
            return make_grid(*node["grid"])
        if "class" in node:
            cls = _allowed_class(node["class"], where)
            if "fields" in node and dataclasses.is_dataclass(cls):
                return _dataclass(cls, node["fields"], arrays, where)
            if "items" in node and not dataclasses.is_dataclass(cls):
                return cls(*(decode(v, arrays, f"{where}[{i}]")
                             for i, v in enumerate(node["items"])))
    raise ValueError(f"{where}: malformed node {node!r:.120}")
