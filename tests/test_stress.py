"""A short run of experiments/stress_batched.py: vmapped value-and-gradient calls, each in a
subprocess under a watchdog, must never hang (issue 17, defect 7).

The laws and the Newton transfer run with jaxlpm's CPU runtime settings (XLA's
concurrency-optimised scheduler off, `jaxlpm/_cpu_runtime.py`): the batched LAPACK calls of the
KKT law and of the Newton transfer still run under vmap, so this guards the mitigation, not a
fix. About 60 s with a cold compilation cache (compiles dominate), 20 s warm.
"""

import json
import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).resolve().parent.parent / "experiments" / "stress_batched.py"


def run_stress(out, *options):
    cmd = [sys.executable, str(SCRIPT), "--out", str(out), "--batches", "8", "--repeats", "3",
           "--stall-s", "20", "--timeout-s", "240", *options]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=900)
    records = [json.loads(line) for line in out.read_text().splitlines()]
    return proc, records


def test_batched_value_and_gradient_never_hangs(tmp_path):
    laws = tmp_path / "laws.jsonl"
    proc, records = run_stress(laws, "--calls", "2", "--cases", "kkt/linear,stm/linear",
                               "--n-laws", "65")
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert [(r["method"], r["outcome"], r["finite"]) for r in records] == [
        ("kkt", "ok", True), ("stm", "ok", True)]
    assert "hangs: 0 of 2 calls" in proc.stdout

    newton = tmp_path / "newton.jsonl"
    proc, records = run_stress(newton, "--calls", "1", "--cases", "newton/linear",
                               "--n-newton", "9")
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert [(r["outcome"], r["finite"], r["workaround"]) for r in records] == [
        ("ok", True, True)]

    # resumable: the same plan again finds every call recorded and runs none
    before = laws.read_text()
    proc, _ = run_stress(laws, "--calls", "2", "--cases", "kkt/linear,stm/linear",
                         "--n-laws", "65")
    assert proc.returncode == 0 and "0 to run" in proc.stdout
    assert laws.read_text() == before
