"""No hang in batched value-and-gradient calls (issue 17, defect 7).

The cause: jaxlib 0.10's batched CPU LAPACK kernels split a batch over XLA's intra-op thread
pool and block until it is done; two at once deadlock a 2-thread pool
(`jaxlpm.linalg.sequential_when_batched`). The fix: the laws and the Newton transfer make no
batched LAPACK call under vmap. Two guards:
- structural: the lowered `jit(vmap(value_and_grad(cost)))` of every law (and of the CARE)
  has no LAPACK custom call with a batch dimension (35, 3, 15, 6 and 21 before the fix);
- behavioural: a short run of experiments/stress_batched.py, each call in a subprocess under
  a watchdog, with XLA's concurrency-optimised scheduler ON (`--no-workaround`), the setting
  in which the KKT law hung on its first call at every batch size tried before the fix.
About 60 s with a cold compilation cache (compiles dominate).
"""

import json
import re
import subprocess
import sys
from pathlib import Path

import jax
import jax.numpy as jnp
import pytest

import jaxlpm as lpm

SCRIPT = Path(__file__).resolve().parent.parent / "experiments" / "stress_batched.py"
ORBIT = lpm.KeplerOrbit(a=9500e3, e=0.3)
X0 = jnp.array([10e3, 10e3, 100.0, 4.0, -23.485, 0.1])
LAPACK = re.compile(r'custom_call @(\w*lapack\w*)\(.*?num_batch_dims = "(\d+)"')


@pytest.mark.parametrize("method, model, n", [("kkt", "linear", 17), ("stm", "linear", 17),
                                              ("newton", "linear", 9),
                                              ("newton", "two-body", 9)])
def test_no_batched_lapack_call_under_vmap(method, model, n):
    def cost(e):
        prob = lpm.EnergyOptimalTransfer.from_revolutions(ORBIT.replace(e=e), X0,
                                                          jnp.zeros(6), 1.0, model=model)
        return lpm.solve(prob, lpm.lgl(n), method=method).cost

    text = jax.jit(jax.vmap(jax.value_and_grad(cost))).lower(jnp.linspace(0.1, 0.3, 5)).as_text()
    calls = LAPACK.findall(text)
    assert calls, "no LAPACK call found: the pattern no longer matches jaxlib's lowering"
    assert [name for name, dims in calls if dims != "0"] == []


def test_no_batched_lapack_call_in_a_vmapped_care_gradient():
    """The CARE's Newton-Kleinman solve, its validity checks and its gain: member by member
    under vmap too (it had 21 batched LAPACK calls)."""
    a = jnp.asarray(lpm.dynamics.hcw_matrix(1.0))
    b = jnp.vstack([jnp.zeros((3, 3)), jnp.eye(3)])
    f = jax.value_and_grad(lambda q: lpm.care(a, b, q * jnp.eye(6), jnp.eye(3)).K.sum())
    calls = LAPACK.findall(jax.jit(jax.vmap(f)).lower(jnp.ones(4)).as_text())
    assert calls and [name for name, dims in calls if dims != "0"] == []


def run_stress(out, *options):
    cmd = [sys.executable, str(SCRIPT), "--out", str(out), "--batches", "8", "--repeats", "3",
           "--stall-s", "20", "--timeout-s", "240", "--no-workaround", *options]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=900)
    records = [json.loads(line) for line in out.read_text().splitlines()]
    return proc, records


def test_batched_value_and_gradient_never_hangs(tmp_path):
    laws = tmp_path / "laws.jsonl"
    proc, records = run_stress(laws, "--calls", "2", "--cases", "kkt/linear,stm/linear",
                               "--n-laws", "65")
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert [(r["method"], r["outcome"], r["finite"], r["workaround"]) for r in records] == [
        ("kkt", "ok", True, False), ("stm", "ok", True, False)]
    assert "hangs: 0 of 2 calls" in proc.stdout

    newton = tmp_path / "newton.jsonl"
    proc, records = run_stress(newton, "--calls", "1", "--cases", "newton/linear",
                               "--n-newton", "9")
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert [(r["outcome"], r["finite"], r["workaround"]) for r in records] == [
        ("ok", True, False)]

    # resumable: the same plan again finds every call recorded and runs none
    before = laws.read_text()
    proc, _ = run_stress(laws, "--calls", "2", "--cases", "kkt/linear,stm/linear",
                         "--n-laws", "65")
    assert proc.returncode == 0 and "0 to run" in proc.stdout
    assert laws.read_text() == before
