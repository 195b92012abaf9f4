"""Command line: `jaxlpm reproduce <case> [--json FILE] [--out DIR]`, `jaxlpm list`."""

import argparse
import json
import os
import sys
import time
from pathlib import Path


def _setup_jax():
    """float64 on, persistent compilation cache (JAXLPM_CACHE_DIR, default ~/.cache/jaxlpm)."""
    import jax

    jax.config.update("jax_enable_x64", True)
    cache = os.environ.get("JAXLPM_CACHE_DIR", str(Path.home() / ".cache" / "jaxlpm" / "jax"))
    jax.config.update("jax_compilation_cache_dir", cache)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.5)
    return cache


def _reproduce(args):
    t0 = time.perf_counter()

    def log(msg):
        print(msg, flush=True)

    log(f"jaxlpm reproduce {args.case}: importing JAX and the library ...")
    cache = _setup_jax()
    from .cases import CASES

    case = CASES[args.case]
    log(f"{case.TITLE}\ncompilation cache: {cache}")
    out_dir = Path(args.out) if args.out else Path("results") / case.NAME
    result = case.reproduce(out_dir, log)
    json_path = Path(args.json) if args.json else out_dir / f"{case.NAME}.json"
    json_path.parent.mkdir(parents=True, exist_ok=True)
    json_path.write_text(json.dumps(result, indent=2))
    log(f"wrote {json_path}\ndone in {time.perf_counter() - t0:.1f} s")
    return 0


def _list(args):
    from .cases import CASES

    for name, case in CASES.items():
        print(f"{name:<12}{case.TITLE}")
    return 0


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
    args = parser.parse_args(argv)
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
