"""The tutorials in examples/ run at small sizes, say what they should and write their figures
(and the rendezvous its OEM) into the folder they are given (issue 20; docs/tutorials/). Each
stays short (at most 60 non-blank lines with its docstring) and uses the public API only."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest

import jaxlpm as lpm

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def load(name):
    spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("name", sorted(p.stem for p in EXAMPLES.glob("*.py")))
def test_examples_are_short_and_use_the_public_api(name):
    lines = [ln for ln in (EXAMPLES / f"{name}.py").read_text().splitlines() if ln.strip()]
    assert len(lines) <= 60, f"{name}: {len(lines)} non-blank lines"
    assert "jaxlpm." not in " ".join(ln for ln in lines if ln.startswith(("from", "import"))), \
        "examples import only `jaxlpm as lpm`"


def is_png(path):
    return path.is_file() and path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_eccentric_rendezvous(capsys, tmp_path):
    """33 points over 3 periods at e = 0.3 (not yet resolved: the flown misses are metres to
    km; 65 points give millimetres, docs/newton.md): both plans converge and say they are not
    resolved (INACCURATE), and on the J2 model the J2 plan misses far less than the linear
    one (the linearisation, not the grid, is what the linear plan lacks). Its figures and the
    J2 plan's OEM are written."""
    plans = load("eccentric_rendezvous").main(points=33, out=tmp_path)
    assert all(int(s.status) == lpm.Status.INACCURATE for s in plans.values())
    misses = {k: float(lpm.verify.fly(s, model="j2").terminal_error[0])
              for k, s in plans.items()}
    assert misses["J2 plan"] < 0.1 * misses["linear plan"], misses
    assert "miss on J2" in capsys.readouterr().out
    assert is_png(tmp_path / "trajectory.png") and is_png(tmp_path / "controls.png")
    oem = (tmp_path / "deputy_j2.oem").read_text()
    assert oem.startswith("CCSDS_OEM_VERS") and "REF_FRAME = EME2000" in oem


def test_sensitivity_study(tmp_path):
    """4 x 4 cases on lgl(17): every case converges (SUCCESS, or INACCURATE where 17 points do
    not resolve it); the implicit gradient dJ/de of one case
    matches central differences of the same vmapped study (h = 1e-6: truncation ~1e-12,
    round-off ~1e-10 relative; 1e-5 asserted)."""
    study = load("sensitivity_study")
    e, rev, J, dJ_de, _, status = study.main(n=4, points=17, out=tmp_path)
    assert is_png(tmp_path / "maps.png")
    assert np.all(np.isin(np.asarray(status), [lpm.Status.SUCCESS, lpm.Status.INACCURATE]))
    k = 5
    h = 1e-6
    grid = lpm.lgl(17)

    def cost(e_):
        o = lpm.KeplerOrbit(a=6650e3 / (1.0 - e_), e=e_)
        x0 = np.array([10e3, 10e3, 0.0, 4.0, -23.485, 0.0])
        p = lpm.EnergyOptimalTransfer(o, x0, np.zeros(6), float(rev[k]) * o.period)
        return float(lpm.solve(p, grid, throw=False).cost)

    fd = (cost(float(e[k]) + h) - cost(float(e[k]) - h)) / (2 * h)
    assert float(dJ_de[k]) == pytest.approx(fd, rel=1e-5)


def test_monte_carlo_j2(tmp_path):
    """4 dispersed J2 rendezvous on lgl(17), re-planned by Newton-KKT through the sweep
    engine: every sample converges (SUCCESS, or INACCURATE on so small a grid), and each record
    obeys Cauchy-Schwarz between its delta-v and its energy cost, dv^2 <= 2 J T (equality only
    for a constant |u|). Its figures and the resumable samples are written."""
    result = load("monte_carlo_j2").main(n=4, points=17, out=tmp_path)
    assert is_png(tmp_path / "histograms.png") and is_png(tmp_path / "dispersion.png")
    assert (tmp_path / "samples-4x17" / "manifest.json").is_file()
    t = result.tables[17]
    assert np.all(np.isin(t["status"], [lpm.Status.SUCCESS, lpm.Status.INACCURATE]))
    assert np.all(t["delta_v"] ** 2 <= 2.0 * t["cost"] * t["duration"])
    assert np.all(t["delta_v"] > 0.0)


def test_design_under_uncertainty(tmp_path):
    """2 samples, 2 Adam steps from each of the 4 starts and a 3 x 3 brute force on lgl(129)
    (129 points resolve every duration of the box: all SUCCESS). The solve counts are the
    ones the tutorial compares (4 x 2 x 2 against 3 x 3 x 2); a second call resumes every
    run from its folder and gives the same histories; the map is written."""
    example = load("design_under_uncertainty")
    runs, best, brute = example.main(samples=2, steps=2, cells=3, points=129, out=tmp_path)
    assert is_png(tmp_path / "design_map.png")
    assert [len(r.history) for r in runs] == [2, 2, 2, 2]
    assert all(h["success"] == 2 for r in runs for h in r.history)
    assert sum(r.solves for r in runs) == 16 and brute.solves == 18
    assert np.all(brute.success == 2) and np.all(np.isfinite(brute.objective))
    assert best.history[-1]["objective"] == min(r.history[-1]["objective"] for r in runs)
    again, _, _ = example.main(samples=2, steps=2, cells=3, points=129, out=tmp_path)
    assert [r.history for r in again] == [r.history for r in runs]
