"""What a case's `reproduce` starts with (a dry run that compiles its programs while it runs) and
ends with (the report, the figures and the JSON-ready result)."""

import time

from ..compilation import prefetch


def prefetch_case(dry_run, log, what="programs"):
    """Trace the case's programs by `dry_run()` (`jaxlpm.compilation.prefetch`, not waiting:
    they compile two at a time while the real run goes on, each solve waiting for its own) and
    log how long the tracing took and how many compile."""
    t = time.perf_counter()
    n = prefetch(dry_run, log, wait=False)
    log(f"traced the case's {what} in {time.perf_counter() - t:.1f} s; {n} compile two "
        f"at a time while it runs (each solve waits for its own)")


def finish(case, computed, draw, out_dir, log):
    """Print `case.report(computed)`, draw the figures (`draw(out_dir)` -> their paths) into
    out_dir, and return {"schema_version", "case", "published", "computed", "notes"}."""
    case.report(computed, log)
    out_dir.mkdir(parents=True, exist_ok=True)
    for path in draw(out_dir):
        log(f"wrote {path}")
    return {"schema_version": 1, "case": case.NAME, "published": case.PUBLISHED,
            "computed": computed, "notes": case.NOTES}
