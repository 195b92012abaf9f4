"""The long version of the property-based bad-input battery (tests/test_properties.py).

Runs the battery with many random examples per public entry point (concrete and traced under
jit(vmap)) in a subprocess and records the outcome as JSON: the command, the seed, the
example count, passed / failed per test, the wall time and any falsifying example pytest
printed. Each example keeps the test's own watchdog (a hang kills the run with tracebacks).

    python experiments/property_battery.py --examples 200 --seed 1 --out results/property_battery.json
"""

import argparse
import json
import os
import re
import subprocess
import sys
import time
from datetime import datetime, timezone
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--examples", type=int, default=200, help="examples per test")
    ap.add_argument("--seed", type=int, default=1, help="hypothesis seed (random, not derandomized)")
    ap.add_argument("--limit-s", type=float, default=300.0, help="watchdog per example (s)")
    ap.add_argument("--out", default="results/property_battery.json")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, JAXLPM_PROPERTY_EXAMPLES=str(args.examples),
               JAXLPM_PROPERTY_SEED=str(args.seed), JAXLPM_PROPERTY_LIMIT_S=str(args.limit_s))
    cmd = [sys.executable, "-m", "pytest", "-q", "-rA", "-p", "no:cacheprovider",
           f"--hypothesis-seed={args.seed}", "tests/test_properties.py"]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    text = proc.stdout + proc.stderr
    outcomes = {m.group(2): m.group(1) for m in re.finditer(r"^(PASSED|FAILED|ERROR) (\S+)",
                                                             text, re.M)}
    record = dict(
        date=datetime.now(timezone.utc).isoformat(timespec="seconds"),
        command=" ".join([Path(sys.argv[0]).name] + (argv or sys.argv[1:])),
        examples_per_test=args.examples, seed=args.seed, watchdog_s=args.limit_s,
        returncode=proc.returncode, wall_s=round(wall, 1),
        passed=sum(v == "PASSED" for v in outcomes.values()),
        failed=sum(v != "PASSED" for v in outcomes.values()), tests=outcomes,
        falsifying=re.findall(r"changes=\{.*?\}", text),
        hang=("Timeout (" in text), tail=text[-3000:])
    out.write_text(json.dumps(record, indent=2))
    print(f"{record['passed']} passed, {record['failed']} failed in {wall:.0f} s "
          f"({args.examples} examples per test, seed {args.seed}); wrote {out}")
    return 0 if proc.returncode == 0 else 1


if __name__ == "__main__":
    raise SystemExit(main())
