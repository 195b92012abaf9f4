"""What every case's `reproduce` ends with: the report, the figures and the JSON-ready result."""


def finish(case, computed, draw, out_dir, log):
    """Print `case.report(computed)`, draw the figures (`draw(out_dir)` -> their paths) into
    out_dir, and return {"schema_version", "case", "published", "computed", "notes"}."""
    case.report(computed, log)
    out_dir.mkdir(parents=True, exist_ok=True)
    for path in draw(out_dir):
        log(f"wrote {path}")
    return {"schema_version": 1, "case": case.NAME, "published": case.PUBLISHED,
            "computed": computed, "notes": case.NOTES}
