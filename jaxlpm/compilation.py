"""How the library's solvers are compiled: XLA options for programs that run a few times, and
an on-disk cache of whole compiled executables, so that a script run again starts in
seconds.

`compiled(fun, static_argnames=())` is the library's `jax.jit` for its entry points (each
family's solver, the flights). Called with traced arguments (inside a user's jit, vmap or
grad) it is `jax.jit(fun)` and inlines into the caller's program. Called with concrete
arguments it runs an ahead-of-time compiled executable, found in this order:

1. in memory, by (the arguments' pytree structure, shapes and dtypes, the static arguments);
2. on disk (`cache_dir()`): an executable this machine compiled before, serialized with its
   input and output pytree structures by `jax.experimental.serialize_executable`, under a
   key that names everything the program depends on: the function, the arguments' structure
   and shapes, the static arguments, the source of every jaxlpm module, the versions of
   jax, jaxlib and the other numeric packages, XLA_FLAGS, the compile profile and the CPU;
3. else traced, lowered and compiled with the profile's XLA options, then written to disk
   (atomically: parallel test workers share the folder; an unreadable entry is a miss).
JAX's own persistent cache (`jax_compilation_cache_dir`) saves only XLA's compile step:
tracing and lowering, 26 of a warm 38 s `jaxlpm reproduce mei2010` (issue 21), ran again
every time. An executable loads in well under a second (bench_compile.py, 2026-12-05: the
KKT law 0.13 s, the Newton-KKT transfer 0.49 s).

An executable that JAX's persistent cache supplied (a program it had kept from an earlier
compile) is not the one written to disk: serialized again, such an executable fails when
loaded in another process ("NOT_FOUND: Function and_and_fusion not found", jaxlib 0.10.2;
reproduced 2026-12-06 by filling JAX's cache, emptying this one and running `jaxlpm reproduce
mei2010` twice: all 9 entries written by the second run failed in a third). The program is
compiled once more instead, with `FRESH_OPTION` added to its options: an XLA option that only
matters when XLA dumps its programs (none here) but is part of JAX's cache key, so XLA
compiles it (and JAX's cache does not keep it), and that executable is written. Without it, a
program JAX's cache held (after any change of jaxlpm's source, which keys this cache and not
JAX's, or of the argument structure of a program whose compiled code is the same) was traced
and lowered again in every later process: measured 2026-12-07, a warm `jaxlpm reproduce
mei2010` after an edit of one module spent 13 s in its prefetch instead of 0.5 s, run after
run. The first call of an executable loaded from disk still runs to the end and, on such an
error, the program is compiled afresh, overwriting the entry.

Profiles (`set_profile`, or the environment variable JAXLPM_COMPILE):
  "fast" (default)  XLA:CPU with LLVM's optimisation level 0 and the classic loop emitters
                    (xla_cpu_use_fusion_emitters=false). Measured on the 2-core CPU VM
                    (experiments/benchmarks/bench_compile.py, BENCHMARKS.md "Cold start",
                    2026-12-05): mei2010's KKT law compiles in 0.63 s instead of 1.84 s
                    with level 0 alone and 2.85 s with XLA's defaults; its Newton-KKT
                    transfer (two-body, lgl(65)) compiles in 4.9 s instead of 11.8 s with
                    XLA's defaults. They then run 1.5-4x slower (24 ms against 6 ms; 0.096 s
                    against 0.027 s). Results agree to round-off.
  "optimized"       XLA's defaults: for a script that calls `solve` thousands of times one by
                    one (batches under jax.vmap inside the user's jax.jit get the user's
                    options in any case).
On platforms other than CPU both profiles are XLA's defaults.

`prefetch(run)` compiles concurrently what a run will need: it calls `run()` once as a dry
run in which every compiled function is traced and lowered (on the calling thread: Python,
the GIL) and handed to a pool of threads to compile (XLA releases the GIL), or, when it is on
disk, handed to the pool to be loaded; its call is answered with zeros of the program's
output shapes (an entry on disk records them) instead of being run; then it waits for the
pool, or with wait=False returns at once, and each call of the real run that follows waits
for its own program only (so the first solves run while the later programs compile).
Tracing the next program overlaps the compiling or loading of the last ones, and two compile
or load at once on two cores. A dry run is per thread, and must not depend on the values it
computes (a loop until convergence would not end on zeros): it is for fixed sequences of
solves such as a reproduction's (`jaxlpm reproduce`); an exception in it ends the dry run
early, and the real run compiles what is left as usual.

`pipelined(run, first, *args)` is the same for one solve: the families' solvers are compiled
as a few programs each (a Newton-KKT transfer: its setup and warm start, its Newton-KKT or
augmented-Lagrangian iterations, its solution and error estimate), and the first solve of a
signature (its first program not in memory) compiles them by a prefetch dry run, so that one
compiles on the second core while the next is traced. mei2010's first Newton-KKT transfer
(two-body, lgl(65)): 6.0-8.3 s as one program, 3.3-4.6 s as three on a noisy 2-core VM
(bench_compile.py, BENCHMARKS.md "Cold start", 2026-12-06, seventh and eighth sessions).

The folder is JAXLPM_CACHE_DIR (default ~/.cache/jaxlpm/jax, the CLI's compilation cache);
JAXLPM_CACHE_DIR="" turns the disk cache off. `clear()` empties the memory cache (the test
suite calls it with `jax.clear_caches()` between modules).
"""

import functools
import hashlib
import importlib.metadata
import inspect
import os
import pickle
import platform
import tempfile
import threading
import time
import types
import warnings
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import jax
import numpy as np

PROFILES = {
    "fast": {"xla_backend_optimization_level": 0, "xla_cpu_use_fusion_emitters": False},
    "optimized": {},
}
_PACKAGES = ("jax", "jaxlib", "numpy", "jaxopt", "diffrax", "equinox", "lineax", "optimistix")
_SUBFOLDER = "executables"
_FORMAT = 2   # bump when the entry's layout changes

_profile = os.environ.get("JAXLPM_COMPILE", "fast")
_memory: dict = {}
_from_disk: set = set()     # keys in _memory loaded from disk and not yet run (`prefetch`)

events: list = []
"""One dict per executable this process compiled (name, source "compiled", profile, trace_s,
lower_s, compile_s, jax_cache_hit (JAX's persistent cache supplied it), and hlo_lines, the
lowered StableHLO's size, when `record_hlo`), loaded from disk (name, source "disk", load_s)
or loaded and failed when first run (name, source "disk", failed, error): what a first run
spent its time on (experiments/benchmarks/bench_compile.py reads it)."""
record_hlo = False


def set_profile(name: str) -> None:
    """Compile the library's solvers with profile `name` ("fast" or "optimized"; module
    docstring) from now on; executables already compiled stay as they are."""
    global _profile
    if name not in PROFILES:
        raise ValueError(f"profile must be one of {sorted(PROFILES)}, got {name!r}")
    _profile = name


def profile() -> str:
    """The current compile profile's name."""
    if _profile not in PROFILES:
        raise ValueError(f"JAXLPM_COMPILE must be one of {sorted(PROFILES)}, got {_profile!r}")
    return _profile


def compiler_options() -> dict:
    """The XLA options of the current profile on this backend."""
    return dict(PROFILES[profile()]) if jax.default_backend() == "cpu" else {}


def cache_dir() -> Path | None:
    """The folder of the executable cache (module docstring), None when it is off."""
    root = os.environ.get("JAXLPM_CACHE_DIR")
    if root == "":
        return None
    root = Path(root) if root else Path.home() / ".cache" / "jaxlpm" / "jax"
    return root / _SUBFOLDER


def clear() -> None:
    """Forget the executables held in memory and those a dry run left compiling (those on
    disk stay)."""
    _memory.clear()
    _from_disk.clear()
    _pending.clear()


@functools.cache
def _environment() -> str:
    """What every executable depends on beyond its own arguments (module docstring, 2.)."""
    digest = hashlib.sha256()
    package = Path(__file__).resolve().parent
    for path in sorted(package.rglob("*.py")):
        digest.update(str(path.relative_to(package)).encode())
        digest.update(path.read_bytes())
    versions = []
    for name in _PACKAGES:
        try:
            versions.append(f"{name}={importlib.metadata.version(name)}")
        except importlib.metadata.PackageNotFoundError:
            versions.append(f"{name}=-")
    return "\n".join([digest.hexdigest(), *versions, os.environ.get("XLA_FLAGS", ""),
                      platform.machine(), _cpu_flags(), str(jax.devices()[0])])


def _cpu_flags() -> str:
    try:
        with open("/proc/cpuinfo") as f:
            return next((line for line in f if line.startswith("flags")), "")
    except OSError:
        return platform.processor()


def _aval(leaf):
    """A leaf's shape and dtype for the key, "float64[65,3]". Weak types are left out: an
    executable runs on a weakly or strongly typed leaf of its dtype alike, and a program's
    outputs come back weak where it computed them from Python scalars, which a `prefetch`
    dry run (zeros of the output shapes) cannot tell. Arrays by their attributes (a tenth of
    the time of formatting `jax.typeof`: a staged solve's keys have about a hundred leaves)."""
    if isinstance(leaf, (jax.Array, np.ndarray, np.generic)):
        return f"{leaf.dtype.name}[{','.join(map(str, leaf.shape))}]"
    try:
        return str(jax.typeof(leaf)).lstrip("~")
    except TypeError as err:
        raise TypeError(f"{leaf!r:.80} is not an array or a number: a compiled function takes "
                        f"such an argument in static_argnames") from err


class Compiled:
    """A function compiled once per argument signature (module docstring); call it like
    the function."""

    def __init__(self, fun, static_argnames=()):
        self.fun = fun
        self.name = f"{fun.__module__}.{fun.__qualname__}"
        # on disk only under a name that is unique: a module-level function (lambdas and
        # local functions can share a qualified name)
        self.on_disk = isinstance(fun, types.FunctionType) and "<" not in fun.__qualname__
        static = (static_argnames,) if isinstance(static_argnames, str) else static_argnames
        self.static = tuple(static)
        self.signature = inspect.signature(fun)
        self.dynamic = tuple(n for n in self.signature.parameters if n not in self.static)
        self.jit = jax.jit(self._adapter, static_argnums=1)
        functools.update_wrapper(self, fun)

    def _adapter(self, dynamic, static):
        return self.fun(**dict(zip(self.dynamic, dynamic)), **dict(static))

    def _split(self, args, kwargs):
        bound = self.signature.bind(*args, **kwargs)
        bound.apply_defaults()
        values = bound.arguments
        return (tuple(values[n] for n in self.dynamic),
                tuple((n, values[n]) for n in self.static))

    def _key(self, dynamic, static):
        """The key of a call's executable, or None when it does not run one (traced
        arguments, or jit disabled)."""
        leaves, tree = jax.tree_util.tree_flatten(dynamic)
        if jax.config.jax_disable_jit or any(isinstance(x, jax.core.Tracer) for x in leaves):
            return None
        return (self.name, tree, tuple(_aval(x) for x in leaves), static,
                tuple(sorted(compiler_options().items())))

    def ready(self, *args, **kwargs) -> bool:
        """Whether a call with these arguments would run at once: its executable is in
        memory, or the call does not run one (traced arguments)."""
        key = self._key(*self._split(args, kwargs))
        return key is None or key in _memory or key in _pending

    def __call__(self, *args, **kwargs):
        dynamic, static = self._split(args, kwargs)
        key = self._key(dynamic, static)
        if key is None:
            return self.jit(dynamic, static)
        dry = _dry_run()
        if dry is not None:
            return dry.dry_call(self, key, dynamic, static)
        if key in _pending:
            _collect(key)
        executable = _memory.get(key)
        if executable is not None and key not in _from_disk:
            return executable(dynamic)
        executable = executable if executable is not None else self._load(key)
        if executable is not None:
            # an executable loaded from disk can fail when first run ("Function
            # and_and_fusion not found": module docstring): run it to the end once, and on
            # such an error compile the program afresh (overwriting the entry)
            _from_disk.discard(key)
            try:
                out = jax.block_until_ready(executable(dynamic))
                _memory[key] = executable
                return out
            except jax.errors.JaxRuntimeError as err:
                events.append(dict(name=self.name, source="disk", failed=True,
                                   error=str(err)[:300]))
        executable = _memory[key] = self._compile(key, *self._lower(dynamic, static))
        return executable(dynamic)

    def _read(self, key):
        """The entry on disk (`_read`), or None."""
        path = _entry(key) if self.on_disk else None
        return _read(path) if path is not None and path.exists() else None

    def _load(self, key, entry=None):
        """The executable of `entry` (default: read from disk), or None; its load recorded
        in `events`. Any thread."""
        t0 = time.perf_counter()
        entry = self._read(key) if entry is None else entry
        executable = _deserialize(entry) if entry is not None else None
        if executable is not None:
            events.append(dict(name=self.name, source="disk", load_s=time.perf_counter() - t0))
        return executable

    def _lower(self, dynamic, static):
        """(lowered program, event with its trace and lower times)."""
        t0 = time.perf_counter()
        traced = self.jit.trace(dynamic, static)
        t1 = time.perf_counter()
        lowered = traced.lower()
        t2 = time.perf_counter()
        event = dict(name=self.name, source="compiled", profile=profile(), trace_s=t1 - t0,
                     lower_s=t2 - t1)
        if record_hlo:
            event["hlo_lines"] = lowered.as_text().count("\n")
        return lowered, event

    def _compile(self, key, lowered, event):
        """Compile (any thread), record the event, write the executable to disk; where JAX's
        own persistent cache supplied it, the disk gets a fresh compile instead (module
        docstring)."""
        t0 = time.perf_counter()
        executable, from_jax_cache = _compile_counting(lowered, compiler_options())
        event = dict(event, compile_s=time.perf_counter() - t0, jax_cache_hit=from_jax_cache)
        # only the fast profile's executables go to disk: "optimized" relies on JAX's own
        # cache (its executables were the first seen to fail when loaded, before the cause
        # in the module docstring was found)
        path = _entry(key) if self.on_disk and profile() == "fast" else None
        if path is not None and from_jax_cache:
            # another process (a test worker) may just have written it
            t1 = time.perf_counter()
            fresh = None if path.exists() else _compiled_past_jax_cache(lowered)
            event["fresh_compile_s"] = time.perf_counter() - t1
            path, executable = (None, executable) if fresh is None else (path, fresh)
        events.append(event)
        if path is not None:
            _store(path, executable)
        return executable


FRESH_OPTION = {"xla_dump_large_constants": True}
"""Added to a program's XLA options to compile it past JAX's persistent cache (module
docstring): it changes only what XLA writes when it dumps programs, and JAX's cache key
keeps it (unlike the xla_dump_to family, which the key clears)."""


def _compiled_past_jax_cache(lowered):
    """The program compiled with `FRESH_OPTION` and kept out of JAX's persistent cache (or the
    next fresh compile of it, after another change of jaxlpm's source, would come from that
    cache again), by JAX's minimum compile time for a cache entry: a thread-local setting
    without a public name in jax 0.10. None where this jax lacks it, or JAX's cache supplied
    the program all the same: it is then not written (as before 2026-12-07)."""
    from jax._src import config

    setting = getattr(config, "persistent_cache_min_compile_time_secs", None)
    if setting is None:
        return None
    with setting(float("inf")):
        executable, from_jax_cache = _compile_counting(lowered,
                                                       {**compiler_options(), **FRESH_OPTION})
    return None if from_jax_cache else executable


def _compile_counting(lowered, options):
    """(executable, whether JAX's persistent cache supplied it)."""
    hits = _jax_cache_hits()
    executable = lowered.compile(options)
    return executable, _jax_cache_hits() > hits


_local = threading.local()


def _count_jax_cache_hit(event, **kwargs):
    if event == "/jax/compilation_cache/cache_hits":
        _local.jax_cache_hits = _jax_cache_hits() + 1


def _jax_cache_hits() -> int:
    """How many programs this thread has had from JAX's persistent compilation cache."""
    return getattr(_local, "jax_cache_hits", 0)


jax.monitoring.register_event_listener(_count_jax_cache_hit)


class _Prefetch:
    """A `prefetch` dry run's state: the pool its compiles and loads are submitted to."""

    def __init__(self, workers, log):
        self.pool = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="jaxlpm-compile")
        self.keys, self.log, self.compiling, self.compiled = [], log, 0, 0
        self.lock = threading.Lock()

    def dry_call(self, fn, key, dynamic, static):
        """Zeros of the program's outputs; the program submitted to the pool to be loaded
        from disk, or lowered and submitted to be compiled (`_pending`)."""
        known = _memory.get(key)
        if known is None and key not in _pending:
            entry = fn._read(key)
            if entry is not None:
                _prepare_runtime()              # on this thread, before any load
                _pending[key] = (self.pool.submit(fn._load, key, entry), _output_info(entry),
                                 "loaded")
            else:
                lowered, event = fn._lower(dynamic, static)
                future = self.pool.submit(fn._compile, key, lowered, event)
                _pending[key] = (future, lowered.out_info, "compiled")
                self.compiling += 1
                if self.log is not None:
                    self.log(f"compiling {self.compiling}: {fn.name}")
                    future.add_done_callback(lambda _, name=fn.name: self._compiled(name))
            self.keys.append(key)
        info = known.out_info if known is not None else _pending[key][1]
        # NumPy zeros: jnp.zeros would compile a broadcast per output shape
        return jax.tree_util.tree_map(lambda a: np.zeros(a.shape, a.dtype), info)

    def _compiled(self, name):
        with self.lock:
            self.compiled += 1
            self.log(f"compiled {self.compiled} of {self.compiling}: {name}")

    def finish(self, wait):
        """Wait for every program submitted (wait), or leave them to finish in the pool's
        threads; either way a call needing one waits for it (`_collect`)."""
        if wait:
            for key in self.keys:
                _collect(key)
        self.pool.shutdown(wait=False)


_pending: dict = {}
"""key -> (future, output shapes, "loaded" or "compiled"): what dry runs submitted and no
call has collected yet (`_collect`)."""


def _collect(key):
    """The executable of a submitted compile or load, once done, put in memory (one loaded
    from disk is checked by its first real call); None where it would not load (a miss) or
    another thread collected it first."""
    item = _pending.pop(key, None)
    if item is None:
        return None
    future, _, how = item
    executable = future.result()
    if executable is not None:
        _memory[key] = executable
        if how == "loaded":
            _from_disk.add(key)
    return executable


def _dry_run() -> _Prefetch | None:
    """The dry run this thread is in, or None (per thread: another thread's solves run as
    usual meanwhile)."""
    return getattr(_local, "dry_run", None)


def prefetch(run, log=None, workers: int = 2, wait: bool = True) -> int:
    """Compile what `run()` needs, `workers` programs at a time, by a dry run (module
    docstring); returns the number of programs submitted to compile. log(str): a line per
    program submitted and per program compiled. wait=False returns once the dry run has
    traced them all: the real run can start on the first ones while the others still compile
    (a call waits for its own program). Not reentrant: inside a prefetch, runs `run` as is;
    per thread."""
    if _dry_run() is not None:
        run()
        return 0
    state = _local.dry_run = _Prefetch(workers, log)
    try:
        # the dry run's zeros may meet host arithmetic (a burn's delta-v divides by its zero
        # mass flow): its values are discarded, and so are NumPy's warnings about them
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            run()
    except Exception as err:                            # noqa: BLE001 (the real run will tell)
        if log is not None:
            log(f"dry run stopped early ({type(err).__name__}: {err}); the rest compiles "
                f"as it is reached")
    finally:
        _local.dry_run = None
        state.finish(wait)
    return state.compiling


def pipelined(run, first, *args, **kwargs):
    """run(), a fixed sequence of compiled calls whose first is first(*args, **kwargs).
    Where that one is not in memory, `prefetch(run)` first: each program is traced in turn and
    compiled (or loaded from disk) on a second core while the next one is traced, instead of
    one after the other (module docstring). Inside a prefetch, or traced, run() as it is."""
    if _dry_run() is None and not first.ready(*args, **kwargs):
        prefetch(run, wait=False)
    return run()


def compiled(fun=None, *, static_argnames=()):
    """`Compiled(fun, static_argnames)`; usable as a decorator with or without arguments."""
    if fun is None:
        return functools.partial(compiled, static_argnames=static_argnames)
    return Compiled(fun, static_argnames)


def _entry(key):
    """The file of an executable, None when the disk cache is off or the key is not stable
    across processes (an argument whose repr holds a memory address)."""
    folder = cache_dir()
    text = repr(key)
    if folder is None or " at 0x" in text:
        return None
    digest = hashlib.sha256(f"{_FORMAT}\n{_environment()}\n{text}".encode()).hexdigest()
    return folder / f"{key[0].rsplit('.', 1)[-1]}-{digest[:32]}.bin"


@functools.cache
def _prepare_runtime():
    """jaxlib binds its LAPACK kernels (QR, LU, SVD, ...) when a program using them is first
    lowered; an executable loaded in a process that has lowered none crashes in its first
    LAPACK call. Lowering one QR (no compile, ~0.05 s) binds them by the public path."""
    import jax.numpy as jnp

    jax.jit(jnp.linalg.qr).lower(np.eye(2))


def _read(path):
    """An entry: (serialized executable, input tree, output tree, [(shape, dtype) of each
    output leaf]), or None where it cannot be read."""
    try:
        entry = pickle.loads(path.read_bytes())
    except Exception:                                   # noqa: BLE001 (unreadable: a miss)
        return None
    return entry if isinstance(entry, tuple) and len(entry) == 4 else None


def _output_info(entry):
    """The outputs' shapes and dtypes of an entry, as the executable's `out_info` gives them
    (what a `prefetch` dry run answers with before the executable is loaded)."""
    _, _, out_tree, outputs = entry
    return out_tree.unflatten([jax.ShapeDtypeStruct(shape, np.dtype(dtype))
                               for shape, dtype in outputs])


def _deserialize(entry):
    """The executable of an entry, or None (any thread, once `_prepare_runtime` has run)."""
    from jax.experimental.serialize_executable import deserialize_and_load

    _prepare_runtime()
    try:
        return deserialize_and_load(*entry[:3])
    except Exception:                                   # noqa: BLE001 (unreadable: a miss)
        return None


def _store(path, executable):
    """Write an executable (silently nothing for one that cannot be serialized: a program
    with host callbacks, e.g. equinox's runtime checks inside diffrax's integrators)."""
    from jax.experimental.serialize_executable import serialize

    outputs = [(tuple(a.shape), np.dtype(a.dtype).str)
               for a in jax.tree_util.tree_leaves(executable.out_info)]
    try:
        blob = pickle.dumps((*serialize(executable), outputs))
    except Exception:                                   # noqa: BLE001 (not serializable)
        return
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-")
        with os.fdopen(fd, "wb") as f:
            f.write(blob)
        os.replace(tmp, path)
    except OSError as err:
        warnings.warn(f"jaxlpm could not cache a compiled solver in {path.parent}: {err}",
                      RuntimeWarning, stacklevel=4)
