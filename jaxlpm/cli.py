"""Command line: `jaxlpm reproduce <case> [--json FILE] [--out DIR]`, `jaxlpm list`,
`jaxlpm sweep <case> --e A:B:n --revolutions A:B:n --points 17,33,65[,refine] [--method kkt]
[--out DIR] [--sensitivities]` (resumable; see `jaxlpm.batch.sweep`). Grid sizes are numbers of
points (lgl(65): 65 points, Mei 2010's degree N = 64); "refine" adds adaptive mesh refinement."""

import argparse
import json
import os
import sys
import threading
import time
from pathlib import Path


def _setup_jax():
    """float64 on, persistent compilation cache (JAXLPM_CACHE_DIR, default ~/.cache/jaxlpm)."""
    import jax

    jax.config.update("jax_enable_x64", True)
    cache = os.environ.get("JAXLPM_CACHE_DIR", str(Path.home() / ".cache" / "jaxlpm" / "jax"))
    jax.config.update("jax_compilation_cache_dir", cache)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
    return cache


def _why_unwritable(path: Path, directory: bool) -> str | None:
    """Why `path`, a directory to create or write into (or a file to write), cannot be
    written, or None; creates nothing."""
    if path.exists():
        if path.is_dir() != directory:
            return "it is not a directory" if directory else "it is a directory"
        target = path
    else:
        target = next(p for p in path.absolute().parents if p.exists())
        if not target.is_dir():
            return f"{target} is not a directory"
    if not os.access(target, os.W_OK | (os.X_OK if target.is_dir() else 0)):
        return f"no write permission on {target}"
    return None


def _require_writable(prog: str, paths: dict) -> None:
    """Exit with status 2 and a one-line message on stderr if one of `paths` ({option:
    (path, is a directory)}) cannot be written: checked before any computation."""
    for option, (path, directory) in paths.items():
        why = _why_unwritable(path, directory)
        if why is not None:
            print(f"{prog}: error: cannot write {option} {path}: {why}", file=sys.stderr)
            raise SystemExit(2)


class _Heartbeat:
    """The reproductions' log: prints a line, and while used as a context, a line every
    `every` seconds without one, saying what is still running (a first compile can take tens
    of seconds on a small machine). 8 s, checked twice a second: no silence reaches 10 s
    (issue 21), although a busy interpreter can delay the check."""

    def __init__(self, t0, every=8.0):
        self.t0, self.every = t0, every
        self.last, self.message = time.perf_counter(), ""
        self._stop = threading.Event()

    def __call__(self, msg):
        self.last, self.message = time.perf_counter(), str(msg).strip().splitlines()[-1:]
        print(msg, flush=True)

    def _beat(self):
        while not self._stop.wait(0.5):
            now = time.perf_counter()
            if now - self.last >= self.every:
                self.last = now
                doing = self.message[0] if self.message else "starting"
                print(f"  ... {now - self.t0:.0f} s, still on: {doing}", flush=True)

    def __enter__(self):
        self._thread = threading.Thread(target=self._beat, daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._thread.join()


def _reproduce(args):
    t0 = time.perf_counter()
    from .cases import CASES

    case = CASES[args.case]
    out_dir = Path(args.out) if args.out else Path("results") / case.NAME
    json_path = Path(args.json) if args.json else out_dir / f"{case.NAME}.json"
    _require_writable("jaxlpm reproduce", {"--out": (out_dir, True),
                                           "--json": (json_path, False)})

    log = _Heartbeat(t0)
    log(f"jaxlpm reproduce {args.case}: importing JAX and the library ...")
    cache = _setup_jax()
    log(f"{case.TITLE}\ncompilation cache: {cache}")
    with log:
        result = case.reproduce(out_dir, log)
    json_path.parent.mkdir(parents=True, exist_ok=True)
    json_path.write_text(json.dumps(result, indent=2))
    log(f"wrote {json_path}\ndone in {time.perf_counter() - t0:.1f} s")
    return 0


def _list(args):
    from .cases import CASES

    for name, case in CASES.items():
        print(f"{name:<12}{case.TITLE}")
    return 0


SWEEP_CASES = ("mei2010",)      # cases whose `problem()` is an EnergyOptimalTransfer to sweep about


def _values(text, integer=False):
    """'a:b:n' -> n values linspace(a, b, n); 'v1,v2,...' -> those values."""
    import numpy as np

    try:
        if ":" in text:
            a, b, n = text.split(":")
            if int(n) < 1:
                raise ValueError
            values = np.linspace(float(a), float(b), int(n))
        else:
            values = np.array([float(v) for v in text.split(",")])
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected 'start:stop:count' (linspace, count >= 1) or comma-separated values, "
            f"got {text!r}") from None
    if integer:
        if not np.all(values == np.round(values)):
            raise argparse.ArgumentTypeError(f"expected integers, got {text!r}")
        return sorted({int(v) for v in values})
    return values


def _points(text):
    """--points: grid sizes ('17,33,65' or 'a:b:n') and/or 'refine' (adaptive refinement)."""
    from .batch.sweep import REFINE

    tokens = text.split(",")
    refine = REFINE in tokens
    rest = ",".join(t for t in tokens if t != REFINE)
    return (_values(rest, integer=True) if rest else []) + ([REFINE] if refine else [])


def _sweep(args):
    import importlib

    out = Path(args.out) if args.out else Path("results") / f"sweep_{args.case}_{args.method}"
    _require_writable("jaxlpm sweep", {"--out": (out, True)})
    cache = _setup_jax()
    from .batch import parameter_grid, sensitivity_family, sweep, transfer_family

    case = importlib.import_module(f".cases.{args.case}", __package__)
    family = transfer_family(args.case, case.problem(), args.method, args.hold)
    if args.sensitivities:
        family = sensitivity_family(family)
    axes = {k: getattr(args, k) for k in ("e", "revolutions", "duration")
            if getattr(args, k) is not None}
    if not axes:
        raise SystemExit("jaxlpm sweep: give at least one of --e, --revolutions, --duration")
    held = family.definition["held_when_e_varies"]
    print(f"jaxlpm sweep {args.case} (method {args.method}): "
          + ", ".join(f"{k} {len(v)} values in [{v.min():g}, {v.max():g}]" for k, v in axes.items())
          + f", grids lgl(points), points = {args.points}; when e varies the chief's {held} is "
          f"held\ncompilation cache: {cache}\nresults: {out}", flush=True)
    try:
        result = sweep(family, parameter_grid(**axes), args.points, out, chunk_size=args.chunk,
                       batch_size=args.batch_size, progress=not args.no_progress)
    except ValueError as err:
        raise SystemExit(f"jaxlpm sweep: {err}") from None
    stats = result.statistics()
    for n, s in result.summary().items():
        bad = s["not_converged"]
        print(f"{n:>4}{'' if n == 'refine' else ' points'}: {s['converged']}/{s['members']} "
              f"converged"
              + (f"; not converged: members {bad[:20]}{' ...' if len(bad) > 20 else ''} "
                 f"({', '.join(f'{k} {v}' for k, v in s['status_counts'].items())})"
                 if bad else ""))
        for col, unit in (("cost", "m^2/s^3"), ("delta_v", "m/s")):
            c = stats[n if n == "refine" else int(n)][col]
            if c["converged"]:
                print(f"         {col} over the converged ({unit}): median "
                      f"{c['percentiles'][50.0]:.6g}, 5-95 % [{c['percentiles'][5.0]:.6g}, "
                      f"{c['percentiles'][95.0]:.6g}], mean {c['mean']:.6g}")
    print(f"results in {out} (manifest.json; points<n>/ and refined/chunk_*.npz, one row per "
          f"member; "
          f"jaxlpm.batch.load_sweep reads them)")
    return 0


class _DegreeGone(argparse.Action):
    """--N (the polynomial degree) is refused with the point counts it meant."""

    def __call__(self, parser, namespace, values, option_string=None):
        try:
            points = ",".join(str(int(v) + 1) for v in values.split(","))
            hint = f" (--N {values} is --points {points})"
        except ValueError:
            hint = ""
        parser.error(f"--N (the polynomial degree N, grid lgl(N + 1)) is no longer accepted: "
                     f"give the grid sizes as numbers of points, --points{hint}")


def main(argv=None):
    from .cases import CASES

    parser = argparse.ArgumentParser(prog="jaxlpm", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    rep = sub.add_parser("reproduce", help="reproduce a paper's case beside its published numbers")
    rep.add_argument("case", choices=sorted(CASES))
    rep.add_argument("--json", help="write the results JSON here (default OUT/<case>.json)")
    rep.add_argument("--out", help="directory for figures (default results/<case>)")
    rep.set_defaults(func=_reproduce)
    lst = sub.add_parser("list", help="list the reproducible cases")
    lst.set_defaults(func=_list)
    swp = sub.add_parser(
        "sweep", help="solve a case's transfer over a grid of e, durations and grid sizes "
                      "(resumable)",
        description="Solve the case's transfer for every combination of the given values at "
                    "every grid size (points); re-running the same command resumes. Values: "
                    "'a:b:n' (linspace) or 'v1,v2,...'.")
    swp.add_argument("case", choices=SWEEP_CASES)
    swp.add_argument("--e", type=_values, help="chief eccentricities")
    dur = swp.add_mutually_exclusive_group()
    dur.add_argument("--revolutions", type=_values, help="durations in chief orbital periods")
    dur.add_argument("--duration", type=_values, help="durations in s")
    swp.add_argument("--points", type=_points, required=True,
                     help="grid sizes as numbers of points, grids lgl(points), e.g. 17,33,65 "
                          "(Mei 2010's degree N = 64 is 65 points), and/or 'refine': adaptive "
                          "mesh refinement to the default tolerance (Newton-KKT on LGR meshes)")
    swp.add_argument("--N", action=_DegreeGone, help=argparse.SUPPRESS)
    swp.add_argument("--method", default="kkt", choices=("kkt", "stm", "newton"),
                     help="kkt/stm: the linear laws (linear model); newton: Newton-KKT on the "
                          "nonlinear two-body model (default kkt)")
    swp.add_argument("--hold", default="perigee", choices=("perigee", "a"),
                     help="what stays fixed when e varies: the chief's perigee radius "
                          "(default) or its semi-major axis")
    swp.add_argument("--chunk", type=int, default=256, help="members per chunk file (256)")
    swp.add_argument("--batch-size", type=int, default=None,
                     help="members a device solves at once (default: its whole share of a "
                          "chunk)")
    swp.add_argument("--out", help="the sweep's directory (default results/sweep_<case>_<method>)")
    swp.add_argument("--sensitivities", action="store_true",
                     help="also store d cost/d p and d delta_v/d p for each swept p and the "
                          "gain d u(t0)/d x0 (implicit differentiation, batched)")
    swp.add_argument("--no-progress", action="store_true", help="no progress bar")
    swp.set_defaults(func=_sweep)
    args = parser.parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
