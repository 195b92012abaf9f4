"""Adaptive mesh refinement inside the sweep and Monte Carlo engines (issue 19 item 4): a
sweep's "refine" group solves every member of a chunk on the ladder's first rung and only the
INACCURATE ones on the next (one compiled function per rung for the chunk's shape), ends each
member where `refine_batch` ends it, counts the members still INACCURATE apart, resumes from
disk, and runs sharded on two devices. A short ladder of small LGR meshes (2 and 4 segments of
8 points) keeps the Newton-KKT programs cheap to compile; with the default tolerance it spans
members that stop on each rung and members still INACCURATE on the last (the long eccentric
ones)."""

import dataclasses
import functools
import json
import os
import subprocess
import sys

import jax
import numpy as np
import pytest

jax.config.update("jax_enable_x64", True)

from jaxlpm.batch import (Refinement, parameter_grid, refine_batch, replan_monte_carlo,  # noqa: E402
                          sensitivity_family, sweep, transfer_family)
from jaxlpm.cases import mei2010  # noqa: E402
from jaxlpm.solvers.refine import MeshLadder  # noqa: E402
from jaxlpm.status import Status  # noqa: E402

LADDER = MeshLadder(((2, 8), (4, 8)))
REFINEMENT = Refinement(ladder=LADDER)
# 6 members in chunks of 4: the second chunk has 2 members and 2 padding rows
PARAMS = parameter_grid(e=[0.0, 0.3, 0.6], revolutions=[1.0, 3.0])
CHUNK = 4
# The same Newton-KKT iterations on the same meshes, compiled into different programs (the
# sweep's shard_map over the chunk, refine_batch's map over the batch): the numbers agree to
# round-off; 1e-10 relative leaves room for XLA fusing the arithmetic differently.
RTOL = 1e-10


def family():
    return transfer_family("mei2010", mei2010.problem(), "kkt")


@pytest.fixture(scope="module")
def refined(tmp_path_factory):
    out = tmp_path_factory.mktemp("refine") / "sweep"
    result = sweep(family(), PARAMS, [9, "refine"], out, chunk_size=CHUNK,
                   refinement=REFINEMENT, progress=False)
    batch = refine_batch(jax.vmap(family().build)(PARAMS), ladder=LADDER)
    return result, batch, out


def manifest(out):
    return json.loads((out / "manifest.json").read_text())


def test_each_member_ends_where_refine_batch_ends_it(refined):
    result, batch, _ = refined
    t = result.tables["refine"]
    np.testing.assert_array_equal(t["index"], np.arange(6))
    np.testing.assert_array_equal(t["rung"], batch["rung"])
    np.testing.assert_array_equal(t["segments"], np.take([2, 4], batch["rung"]))
    np.testing.assert_array_equal(t["status"], batch["status"])
    np.testing.assert_allclose(t["cost"], batch["cost"], rtol=RTOL)
    # the ladder is exercised: members stop on more than one rung, and the last rung leaves
    # some INACCURATE (the long eccentric ones need more than 4 x 8 points)
    assert len(set(t["rung"][t["status"] == Status.SUCCESS])) >= 2
    assert np.any(t["status"] == Status.INACCURATE)
    # a member stops on the first rung whose estimate meets the tolerance: below it, the
    # position error estimate of every SUCCESS member
    ok = t["status"] == Status.SUCCESS
    assert np.all(t["error_position"][ok] <= REFINEMENT.tolerance.position)


def test_inaccurate_members_are_counted_apart(refined):
    result, _, out = refined
    t = result.tables["refine"]
    s = result.summary()["refine"]
    bad = np.flatnonzero(t["status"] != Status.SUCCESS)
    assert s["not_converged"] == bad.tolist()
    assert s["status_counts"].get("INACCURATE", 0) == int(np.sum(t["status"] == Status.INACCURATE))
    stats = result.statistics()["refine"]["cost"]
    assert stats["converged"] == int(np.sum(t["status"] == Status.SUCCESS))
    assert stats["max"] == pytest.approx(np.max(t["cost"][t["status"] == Status.SUCCESS]))
    m = manifest(out)
    assert m["definition"]["points"] == [9, "refine"]
    assert m["definition"]["refinement"]["rungs"] == [[2, 8], [4, 8]]
    assert m["definition"]["refinement"]["method"] == "newton"
    assert "scheme" not in m["definition"]["refinement"]      # LGR: as before it was recorded
    assert sorted(k for k in m["chunks"] if k.startswith("refined/")) == [
        "refined/chunk_00000", "refined/chunk_00001"]
    assert any(c["points"] == "refine" for c in m["compiles"])
    # the fixed-grid group of the same sweep is untouched by the refinement: its own table
    assert np.all(np.isin(result.tables[9]["status"], [Status.SUCCESS, Status.INACCURATE]))


def test_rerun_resumes_without_solving(refined, tmp_path):
    result, _, out = refined
    again = sweep(family(), PARAMS, [9, "refine"], out, chunk_size=CHUNK,
                  refinement=REFINEMENT, progress=False)
    m = manifest(out)
    assert all(c["run"] == 0 for c in m["chunks"].values())
    for name, col in result.tables["refine"].items():
        np.testing.assert_array_equal(again.tables["refine"][name], col)
    # another tolerance, or another scheme, is another sweep
    with pytest.raises(ValueError, match="different sweep"):
        sweep(family(), PARAMS, [9, "refine"], out, chunk_size=CHUNK, progress=False,
              refinement=Refinement(ladder=MeshLadder(LADDER.rungs, scheme="LG")))
    with pytest.raises(ValueError, match="different sweep"):
        sweep(family(), PARAMS, [9, "refine"], out, chunk_size=CHUNK, progress=False,
              refinement=dataclasses.replace(REFINEMENT, tolerance=dataclasses.replace(
                  REFINEMENT.tolerance, position=0.01)))


TWO_DEVICES = """
import jax, json, sys
jax.config.update("jax_enable_x64", True)
import numpy as np
from jaxlpm.batch import Refinement, parameter_grid, sweep, transfer_family
from jaxlpm.cases import mei2010
from jaxlpm.solvers.refine import MeshLadder
r = sweep(transfer_family("mei2010", mei2010.problem(), "kkt"),
          parameter_grid(e=[0.0, 0.3, 0.6], revolutions=[1.0, 3.0]), ["refine"], sys.argv[1],
          chunk_size=4, refinement=Refinement(ladder=MeshLadder(((2, 8), (4, 8)))),
          progress=False)
print("devices", jax.device_count())
"""


def test_two_devices_agree_with_one(refined, tmp_path):
    """The chunk's 4 rows on 2 devices (2 each, each device solving its own active rows):
    the same members on the same rungs with the same costs as the single-device sweep."""
    result, _, _ = refined
    out = tmp_path / "two"
    proc = subprocess.run([sys.executable, "-c", TWO_DEVICES, str(out)], timeout=600,
                          env=dict(os.environ, JAX_NUM_CPU_DEVICES="2"), capture_output=True,
                          text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "devices 2" in proc.stdout
    assert manifest(out)["runs"][0]["devices"] == 2
    from jaxlpm.batch import load_sweep
    two, one = load_sweep(out).tables["refine"], result.tables["refine"]
    for name in ("status", "rung", "segments"):
        np.testing.assert_array_equal(two[name], one[name])
    np.testing.assert_allclose(two["cost"], one["cost"], rtol=RTOL)


def test_replan_monte_carlo_refines(refined):
    """Six draws of mei2010's linear dispersion re-planned with refinement: each sample ends
    where refine_batch ends the same problems (the draw is reproducible from the key; 6 rows,
    as the module fixture's batch, so refine_batch reuses its compiled rungs)."""
    key, n = jax.random.key(7), 6
    disperse = functools.partial(mei2010.dispersion, model="linear")
    result = replan_monte_carlo(key, n, disperse, ["refine"], refinement=REFINEMENT,
                                chunk_size=4, progress=False)
    t = result.tables["refine"]
    batch = refine_batch(disperse(key, n), ladder=LADDER)
    np.testing.assert_array_equal(t["rung"], batch["rung"])
    np.testing.assert_array_equal(t["status"], batch["status"])
    np.testing.assert_allclose(t["cost"], batch["cost"], rtol=RTOL)
    assert result.summary()["refine"]["members"] == n


def test_refuses_what_it_cannot_refine(tmp_path):
    with pytest.raises(ValueError, match="own solver"):
        sweep(sensitivity_family(family()), PARAMS, ["refine"], tmp_path / "x",
              progress=False)
    with pytest.raises(ValueError, match="positive integers.*'refine'"):
        sweep(family(), PARAMS, ["refined"], tmp_path / "x", progress=False)
    assert not (tmp_path / "x").exists()


def test_gradients_on_each_members_final_mesh():
    """Refinement(gradients=True) through the sweep: each member's implicit gradient of the
    cost, taken on its final mesh, is refine_batch's (the same programs per member: 1e-10)."""
    params = parameter_grid(e=[0.0, 0.3], revolutions=[1.0])
    refinement = dataclasses.replace(REFINEMENT, gradients=True)
    t = sweep(family(), params, ["refine"], chunk_size=2, refinement=refinement,
              progress=False).tables["refine"]
    batch = refine_batch(jax.vmap(family().build)(params), ladder=refinement.ladder,
                         gradients=True)
    np.testing.assert_array_equal(t["rung"], batch["rung"])
    for name in ("dcost_dx0", "dcost_dxf", "dcost_dduration", "dcost_dorbit.e"):
        np.testing.assert_allclose(t[name], batch[name], rtol=RTOL,
                                   atol=RTOL * np.max(np.abs(batch[name])))
