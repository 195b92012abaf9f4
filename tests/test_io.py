"""Saving and exporting (issue 20, items 1-3): `jaxlpm.io`.

save/load: every family's Solution (energy-optimal on an LGL grid and on an LGR mesh,
minimum time, fuel-optimal, LQR, an intercept, a vmapped batch), a sweep's SweepResult and an
execution Monte Carlo's dict come back exactly: the same pytree structure, every leaf of the
same kind, dtype and weak type with the same bits, and a loaded solution evaluates states,
controls and costates bit-identically through the same compiled function (no retrace). The
archive opens with numpy.load(allow_pickle=False); a file naming a class outside jaxlpm is
refused.

to_csv: the header names frame and units; the values read back are the solution's own, bit
for bit.

write_oem: the file is read back by an independent parser (the `oem` package) and its
states are compared with an independent computation written here: the chief by our own
Kepler solver (NumPy) or, for the J2 model, by Encke's method integrated with scipy's DOP853,
and the deputy by the LVLH -> inertial map written from the time derivative of the LVLH axes
(not from the frame's angular velocity, as the library does), within 1e-6 m.

Solutions are solved once per module on small grids (status INACCURATE allowed: throw=False).
"""

import dataclasses
import json
import sys
import zipfile
from datetime import datetime, timedelta, timezone

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import jaxlpm as lpm
from jaxlpm.batch import ExecutionErrors, SweepFamily, execution_monte_carlo, load_sweep, sweep
from jaxlpm.cases import tan2011
from jaxlpm.io.csvtable import COLUMNS
from jaxlpm.io.sampling import evaluate as evaluate_at
from jaxlpm.status import Status


# inclined and eccentric, so every rotation of the inertial map matters
ORBIT = lpm.KeplerOrbit(a=9500e3, e=0.3, i=0.9, raan=0.5, argp=1.1, f0=0.2)
CIRCULAR = lpm.KeplerOrbit(a=6878137.0, e=0.0)
X0 = jnp.array([10e3, 10e3, 500.0, 4.0, -23.485, 0.3])
EPOCH = "2026-03-01T12:00:00"


def energy(model="linear"):
    return lpm.EnergyOptimalTransfer.from_revolutions(ORBIT, X0, jnp.zeros(6), 0.5,
                                                      model=model)


def _energy_lgl():
    return lpm.solve(energy(), lpm.lgl(9), method="kkt", throw=False)


def _fuel():
    orbit = lpm.KeplerOrbit(a=6778137.0, e=0.0)
    problem = lpm.FuelOptimalTransfer(orbit, jnp.zeros(6), jnp.array([0.0, 8e3, 0, 0, 0, 0]),
                                      orbit.period, 0.3, 50.0, 1000.0)
    return lpm.solve(problem, lpm.segmented_lgr(lpm.uniform_breaks(0.0, 1.0, 4), 6),
                     throw=False)


def _impulsive():
    elements, _ = tan2011.recover_elements()
    return lpm.solve(tan2011.problem(elements, revolutions=3, branch="left"), throw=False)


def _batched():
    base = energy()
    return jax.vmap(lambda e: lpm.solve(base.replace(orbit=ORBIT.replace(e=e)), lpm.lgl(9),
                                        method="kkt", throw=False))(jnp.array([0.1, 0.2]))


FAMILIES = {
    "energy-lgl": _energy_lgl,
    "energy-lgr-mesh": lambda: lpm.solve(energy(), lpm.lgr_mesh(2, 6), method="newton",
                                         throw=False),
    # an LGL mesh: its breaks are state rows of both segments (issue 19)
    "energy-lgl-mesh": lambda: lpm.solve(energy(), lpm.lgl_mesh(2, 6), method="newton",
                                         throw=False),
    "min-time": lambda: lpm.solve(lpm.MinimumTimeTransfer(
        CIRCULAR, jnp.zeros(6), jnp.array([5.0, 30.0, -3.0, 0.02, 0.5, 0.01]), 1.0, 200.0),
        lpm.lg(8), throw=False),
    "fuel": _fuel,
    "lqr": lambda: lpm.solve(lpm.LQRTransfer(CIRCULAR, X0, 3000.0, 1e-6 * jnp.eye(6),
                                             jnp.eye(3)), 64, throw=False),
    "impulsive": _impulsive,
    "batched": _batched,
}


@pytest.fixture(scope="module")
def solved():
    """solved(name): the family's solution, solved once per module."""
    cache = {}

    def get(name):
        if name not in cache:
            cache[name] = FAMILIES[name]()
        return cache[name]

    return get


# ------------------------------------------------------------------------------------------
# save / load

TRACES = []


@jax.jit
def evaluate(solution):
    """states, controls and costates at 5 times (member by member for a batch); counts its
    traces."""
    TRACES.append(1)

    def one(sol):
        t = jnp.linspace(0.0, 1.0, 5) * sol.duration
        return sol.states(t), sol.controls(t), sol.costates(t)

    for _ in range(jnp.ndim(solution.status)):
        one = jax.vmap(one)
    return one(solution)


def assert_identical(a, b):
    """Same pytree structure (static fields included) and leaves of the same kind, dtype,
    weak type, shape and bits."""
    assert jax.tree_util.tree_structure(a) == jax.tree_util.tree_structure(b)
    for x, y in zip(jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b), strict=True):
        assert type(x) is type(y)
        if isinstance(x, (jax.Array, np.ndarray, np.generic)):
            assert (x.dtype, x.shape) == (y.dtype, y.shape)
            assert getattr(x, "weak_type", False) == getattr(y, "weak_type", False)
            assert np.asarray(x).tobytes() == np.asarray(y).tobytes()
        else:
            assert x == y


@pytest.mark.parametrize("name", list(FAMILIES))
def test_save_load_is_exact(solved, name, tmp_path):
    sol = solved(name)
    path = lpm.io.save(sol, tmp_path / "solution.npz")
    back = lpm.io.load(path)
    assert type(back) is lpm.Solution and type(back.problem) is type(sol.problem)
    assert_identical(sol, back)
    assert back.message == sol.message
    traces = len(TRACES)
    before = evaluate(sol)
    after = evaluate(back)
    assert len(TRACES) - traces <= 1          # the loaded solution reused the compiled function
    for x, y in zip(before, after, strict=True):
        assert np.asarray(x).tobytes() == np.asarray(y).tobytes()
    # no pickle anywhere: numpy opens every member with allow_pickle=False
    with np.load(path, allow_pickle=False) as z:
        for member in z.files:
            z[member]


def test_metadata_says_what_was_saved(solved, tmp_path):
    meta = lpm.io.read_metadata(lpm.io.save(solved("energy-lgl"), tmp_path / "a.npz"))
    assert meta["schema_version"] == lpm.io.SCHEMA_VERSION == 1
    assert meta["jaxlpm_version"] == lpm.__version__
    assert (meta["kind"], meta["problem"], meta["method"], meta["frame"]) == (
        "Solution", "EnergyOptimalTransfer", "kkt", "LVLH")
    assert meta["grid"] == {"scheme": "LGL", "points": 9}
    assert meta["status"] == Status(int(solved("energy-lgl").status)).name
    assert meta["batch_shape"] == []
    meta = lpm.io.read_metadata(lpm.io.save(solved("energy-lgr-mesh"), tmp_path / "b.npz"))
    assert meta["grid"] == {"mesh": "LGRMesh", "segments": 2, "points_per_segment": 6,
                            "breaks": [-1.0, 0.0, 1.0]}
    meta = lpm.io.read_metadata(lpm.io.save(solved("batched"), tmp_path / "c.npz"))
    assert meta["batch_shape"] == [2] and sum(meta["status"].values()) == 2
    assert lpm.io.read_metadata(lpm.io.save(solved("lqr"), tmp_path / "d.npz"))["grid"] == {
        "steps": 64}


def _synthetic_sweep(out):
    """A sweep of a family without a solver (fast): status, a value and a 2-vector per
    member."""
    def solver(p, grid, method, options):
        bad = p["x"] > 0.5
        return dict(status=jnp.where(bad, Status.MAX_ITERATIONS, Status.SUCCESS).astype(
                        jnp.int32), value=p["x"] * grid, vector=jnp.stack([p["x"], -p["x"]]))

    family = SweepFamily(name="synthetic", build=lambda p: p, grid=float, solver=solver,
                         record=dict)
    return sweep(family, dict(x=np.array([0.1, 0.9, 0.3])), [2, 3], out, chunk_size=2,
                 progress=False)


def test_sweep_results_round_trip_and_become_a_dataframe(tmp_path):
    pd = pytest.importorskip("pandas")
    result = _synthetic_sweep(tmp_path / "sweep")
    from_disk = load_sweep(tmp_path / "sweep")
    back = lpm.io.load(lpm.io.save(from_disk, tmp_path / "sweep.npz"))
    assert type(back) is type(from_disk) and back.out == from_disk.out
    assert back.tables.keys() == result.tables.keys() == {2, 3}
    for n, table in result.tables.items():
        assert back.tables[n].keys() == table.keys()
        for k, v in table.items():
            assert back.tables[n][k].dtype == v.dtype and np.array_equal(back.tables[n][k], v)
    assert back.summary() == result.summary()

    frame = lpm.io.to_dataframe(back)
    assert isinstance(frame, pd.DataFrame) and len(frame) == 6           # 3 members x 2 grids
    assert {"index", "points", "x", "status", "value", "vector[0]", "vector[1]"} <= set(frame)
    assert frame["points"].tolist() == [2, 2, 2, 3, 3, 3]
    np.testing.assert_array_equal(frame["value"], np.r_[2 * result.tables[2]["x"],
                                                        3 * result.tables[3]["x"]])
    np.testing.assert_array_equal(frame["vector[1]"], -frame["x"])
    columns = lpm.io.columns(result)
    assert all(isinstance(v, np.ndarray) and v.shape == (6,) for v in columns.values())


def test_execution_monte_carlo_round_trips_and_becomes_a_dataframe(solved, tmp_path):
    pd = pytest.importorskip("pandas")
    result = execution_monte_carlo(jax.random.key(0), solved("energy-lgl"), 3,
                                   ExecutionErrors(magnitude=0.01, position=1.0))
    back = lpm.io.load(lpm.io.save(result, tmp_path / "mc.npz"))
    assert back.keys() == result.keys() and back["model"] == result["model"]
    assert back["statistics"] == result["statistics"]
    for k in ("gain", "axis", "dx0", "final_state", "status", "nominal"):
        assert back[k].dtype == result[k].dtype and np.array_equal(back[k], result[k])
    frame = lpm.io.to_dataframe(back)
    assert isinstance(frame, pd.DataFrame) and len(frame) == 3
    assert {"gain", "axis[2]", "dx0[5]", "final_state[0]", "position_miss", "status"} <= set(
        frame)
    assert not any(c.startswith("nominal") for c in frame)


def test_to_dataframe_without_pandas(monkeypatch):
    monkeypatch.setitem(sys.modules, "pandas", None)
    with pytest.raises(ImportError, match="pip install pandas"):
        lpm.io.to_dataframe({"status": np.zeros(2)})
    with pytest.raises(ValueError, match="SweepResult or a dict"):
        lpm.io.columns([1, 2])


@dataclasses.dataclass(frozen=True)
class Foreign:
    """A dataclass from outside jaxlpm: not saved."""

    value: float


def _archive(path, structure, schema_version=1):
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr("metadata.json", json.dumps(dict(schema_version=schema_version,
                                                     structure=structure)))
    return path


@pytest.mark.parametrize("structure", [
    {"class": "subprocess.Popen", "items": [["true"]]},
    {"class": "builtins.dict", "fields": {}},
    {"class": "jaxlpm.solvers.api.solve", "fields": {}},
    {"class": "jaxlpm.os.system", "items": ["true"]},
])
def test_load_rebuilds_only_jaxlpm_classes(tmp_path, structure):
    with pytest.raises(ValueError, match="not a jaxlpm dataclass or NamedTuple"):
        lpm.io.load(_archive(tmp_path / "evil.npz", structure))


def test_load_and_save_bad_input(tmp_path):
    with pytest.raises(ValueError, match="schema_version 99"):
        lpm.io.load(_archive(tmp_path / "new.npz", None, schema_version=99))
    (tmp_path / "text.npz").write_text("not a zip")
    with pytest.raises(ValueError, match="not a jaxlpm archive"):
        lpm.io.load(tmp_path / "text.npz")
    with pytest.raises(ValueError, match=r"result\['f'\]: cannot save a builtins.function"):
        lpm.io.save({"f": lambda: 0}, tmp_path / "f.npz")
    with pytest.raises(ValueError, match="an array of Python objects"):
        lpm.io.save(np.array([object()]), tmp_path / "o.npz")
    with pytest.raises(ValueError, match="not a jaxlpm dataclass"):
        lpm.io.save(Foreign(1.0), tmp_path / "d.npz")
    with pytest.raises(ValueError, match="traced value"):
        jax.jit(lambda x: lpm.io.save({"x": x}, tmp_path / "t.npz") and x)(1.0)
    assert not list(tmp_path.glob(".*.tmp"))            # no partial file left behind


# ------------------------------------------------------------------------------------------
# CSV


def test_csv_names_frame_and_units_and_holds_the_solution(solved, tmp_path):
    pd = pytest.importorskip("pandas")
    sol = solved("energy-lgl")
    path = lpm.io.to_csv(sol, tmp_path / "transfer.csv")
    header = [line for line in path.read_text().splitlines() if line.startswith("#")]
    assert any("LVLH" in line and "radial" in line for line in header)
    assert any("units: SI" in line and "m/s^2" in line for line in header)
    table = pd.read_csv(path, comment="#")
    assert tuple(table.columns) == COLUMNS and len(table) == lpm.io.DEFAULT_SAMPLES
    t = table["t_s"].to_numpy()
    assert t[0] == 0.0 and t[-1] == float(sol.duration)
    states, controls = (np.asarray(x) for x in evaluate_at(sol, jnp.asarray(t)))
    assert np.array_equal(table.iloc[:, 1:7].to_numpy(), states)        # 17 digits: exact
    assert np.array_equal(table.iloc[:, 7:10].to_numpy(), controls)
    assert np.array_equal(table["u_norm_m_s2"], np.linalg.norm(controls, axis=1))

    times = [0.0, 100.0, float(sol.duration)]
    rows = np.genfromtxt(lpm.io.to_csv(sol, tmp_path / "3.csv", times), delimiter=",",
                         skip_header=3, names=True)
    assert rows["t_s"].tolist() == times
    inertial = lpm.io.to_csv(solved("impulsive"), tmp_path / "intercept.csv",
                             [0.0, 1.0, 10.0, 100.0])
    assert "inertial" in inertial.read_text().splitlines()[1]


@pytest.mark.parametrize("times, match", [
    ([-1.0], r"in \[0, duration\]"), ([np.nan], r"in \[0, duration\]"), ([1e9], "duration"),
    (np.zeros((2, 2)), "1-D"), ([], "non-empty"), (["a"], "real numbers")])
def test_csv_bad_times(solved, tmp_path, times, match):
    with pytest.raises(ValueError, match=match):
        lpm.io.to_csv(solved("energy-lgl"), tmp_path / "x.csv", times)


def test_exports_take_one_solution(solved, tmp_path):
    for export in (lambda s: lpm.io.to_csv(s, tmp_path / "x.csv"),
                   lambda s: lpm.io.write_oem(s, tmp_path / "x.oem", EPOCH)):
        with pytest.raises(ValueError, match="one solution, got a batch of shape"):
            export(solved("batched"))


# ------------------------------------------------------------------------------------------
# CCSDS OEM: the independent references


def _rotation(i, raan, argp):
    """Perifocal -> inertial: R3(raan) R1(i) R3(argp) as matrix products."""
    def r3(x):
        c, s = np.cos(x), np.sin(x)
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])

    c, s = np.cos(i), np.sin(i)
    return r3(raan) @ np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]]) @ r3(argp)


def kepler(orbit, t):
    """[r, v] at t (s after the epoch) from the eccentric anomaly (Newton on Kepler's
    equation, NumPy)."""
    a, e, mu = float(orbit.a), float(orbit.e), float(orbit.mu)
    n = np.sqrt(mu / a**3)
    f0 = float(orbit.f0)
    E0 = 2.0 * np.arctan(np.sqrt((1.0 - e) / (1.0 + e)) * np.tan(0.5 * f0))
    M = E0 - e * np.sin(E0) + n * t
    E = M
    for _ in range(50):
        E = E - (E - e * np.sin(E) - M) / (1.0 - e * np.cos(E))
    b = np.sqrt(1.0 - e**2)
    Edot = n / (1.0 - e * np.cos(E))
    R = _rotation(float(orbit.i), float(orbit.raan), float(orbit.argp))
    return np.r_[R @ (a * np.array([np.cos(E) - e, b * np.sin(E), 0.0])),
                 R @ (a * Edot * np.array([-np.sin(E), b * np.cos(E), 0.0]))]


def gravity(r, mu, j2, r_eq):
    """Two-body + J2 (Curtis 2014, eq. 10.30)."""
    rn = np.linalg.norm(r)
    k = 1.0 - 5.0 * (r[2] / rn) ** 2
    return -mu * r / rn**3 - 1.5 * mu * j2 * r_eq**2 / rn**5 * np.array(
        [r[0] * k, r[1] * k, r[2] * (k + 2.0)])


def j2_chief(problem, ts):
    """[r, v] at ts on the J2 orbit osculating problem.orbit at the epoch: Encke's deviation
    from our Kepler orbit, integrated by scipy's DOP853."""
    o, mu = problem.orbit, float(problem.orbit.mu)
    j2, r_eq = float(problem.j2), float(problem.r_eq)

    def rhs(t, y):
        r_k = kepler(o, t)[:3]
        return np.r_[y[3:], gravity(r_k + y[:3], mu, j2, r_eq) - gravity(r_k, mu, 0.0, r_eq)]

    dev = solve_ivp(rhs, (0.0, ts[-1]), np.zeros(6), method="DOP853", rtol=1e-13, atol=1e-10,
                    t_eval=ts)
    return np.array([kepler(o, t) for t in ts]) + dev.y.T


def lvlh_to_inertial(chief, acc, rho):
    """Deputy [r, v] from the chief's [r, v], its acceleration and the LVLH state: r + C^T
    rho, v + d/dt (C^T rho) = v + C^T rho_dot + dC^T/dt rho, the axes' derivatives written
    directly (x^ = r/|r|, z^ = h/|h|, y^ = z^ x x^)."""
    r, v = chief[:3], chief[3:]
    h, hdot = np.cross(r, v), np.cross(r, acc)
    x, z = r / np.linalg.norm(r), h / np.linalg.norm(h)
    y = np.cross(z, x)
    xdot = (v - np.dot(x, v) * x) / np.linalg.norm(r)
    zdot = (hdot - np.dot(z, hdot) * z) / np.linalg.norm(h)
    ydot = np.cross(zdot, x) + np.cross(z, xdot)
    C, Cdot = np.array([x, y, z]), np.array([xdot, ydot, zdot])
    return np.r_[r + C.T @ rho[:3], v + C.T @ rho[3:] + Cdot.T @ rho[:3]]


def read_oem(path):
    """(metadata, t (s since EPOCH), states [r, v] in m, m/s) by the `oem` package (its
    epochs are astropy Times)."""
    oem = pytest.importorskip("oem")
    (segment,) = oem.OrbitEphemerisMessage.open(path).segments
    states = list(segment.states)
    start = segment.metadata["START_TIME"]
    assert start.isot == EPOCH + ".000000" and start.scale == "utc"
    t = np.array([(s.epoch - start).sec for s in states])
    xv = 1e3 * np.array([np.r_[s.position, s.velocity] for s in states])
    return segment.metadata, t, xv


@pytest.mark.parametrize("model", ["linear", "j2"])
def test_oem_matches_an_independent_propagation(solved, tmp_path, model):
    """The deputy and the chief (two files: an OEM holds one object) on the Keplerian chief
    and on the J2 chief. For the J2 chief the linear solution's LVLH states are put on the J2
    problem (what the export does depends only on the problem's model and the states)."""
    sol = solved("energy-lgl")
    if model == "j2":
        sol = sol.replace(problem=sol.problem.replace(model="j2"))
    deputy = lpm.io.write_oem(sol, tmp_path / "deputy.oem", EPOCH)
    chief = lpm.io.write_oem(sol, tmp_path / "chief.oem", EPOCH, spacecraft="chief",
                             ref_frame="GCRF", object_id="2026-999A")
    meta, t, xv = read_oem(deputy)
    assert (meta["OBJECT_NAME"], meta["OBJECT_ID"], meta["CENTER_NAME"], meta["REF_FRAME"],
            meta["TIME_SYSTEM"]) == ("DEPUTY", "DEPUTY", "EARTH", "EME2000", "UTC")
    assert len(t) == lpm.io.DEFAULT_SAMPLES and t[0] == 0.0
    assert 0.0 <= float(sol.duration) - t[-1] < 1e-6
    meta_c, t_c, xv_c = read_oem(chief)
    assert (meta_c["OBJECT_NAME"], meta_c["OBJECT_ID"], meta_c["REF_FRAME"]) == (
        "CHIEF", "2026-999A", "GCRF")
    np.testing.assert_array_equal(t_c, t)

    problem = sol.problem
    mu, j2, r_eq = float(problem.orbit.mu), float(problem.j2), float(problem.r_eq)
    ref_chief = (j2_chief(problem, t) if model == "j2"
                 else np.array([kepler(problem.orbit, ti) for ti in t]))
    rho = np.asarray(sol.states(jnp.asarray(t)))
    ref = np.array([lvlh_to_inertial(c, gravity(c[:3], mu, j2 if model == "j2" else 0.0,
                                                r_eq), p) for c, p in zip(ref_chief, rho)])
    for got, want in ((xv_c, ref_chief), (xv, ref)):
        position = np.max(np.linalg.norm(got[:, :3] - want[:, :3], axis=1))
        velocity = np.max(np.linalg.norm(got[:, 3:] - want[:, 3:], axis=1))
        print(model, "position", position, "m, velocity", velocity, "m/s")
        assert position < 1e-6 and velocity < 1e-9
    # the deputy is where the solution says relative to the chief: 10 km away at the start
    assert np.linalg.norm(xv[0, :3] - xv_c[0, :3]) == pytest.approx(
        np.linalg.norm(np.asarray(X0[:3])), rel=1e-9)


def test_oem_of_an_intercept_and_its_times(solved, tmp_path):
    sol = solved("impulsive")
    times = [0.0, 0.7e-6, 1000.0, float(sol.duration)]       # 0.7 us rounds to 1 us
    path = lpm.io.write_oem(sol, tmp_path / "intercept.oem",
                            datetime(2026, 3, 1, 14, 0, tzinfo=timezone(timedelta(hours=2))),
                            times, object_name="INTERCEPTOR")
    meta, t, xv = read_oem(path)                  # 14:00 at UTC+2 is the EPOCH, 12:00 UTC
    assert meta["OBJECT_NAME"] == "INTERCEPTOR"
    np.testing.assert_allclose(t[:3], [0.0, 1e-6, 1000.0], rtol=0, atol=1e-9)
    np.testing.assert_allclose(xv, np.asarray(evaluate_at(sol, jnp.asarray(t))[0]), rtol=0,
                               atol=1e-6)
    with pytest.raises(ValueError, match="no chief"):
        lpm.io.write_oem(sol, tmp_path / "x.oem", EPOCH, spacecraft="chief")


@pytest.mark.parametrize("kwargs, match", [
    (dict(ref_frame="ITRF"), "inertial frame"), (dict(epoch="1 March 2026"), "ISO 8601"),
    (dict(epoch=1.0), "datetime or an ISO"), (dict(spacecraft="target"), "spacecraft must"),
    (dict(object_name="A\nB"), "one-line"), (dict(times=[0.0, 1e-7]), "1 microsecond apart"),
    (dict(times=[5.0, 1.0]), "strictly increasing")])
def test_oem_bad_input(solved, tmp_path, kwargs, match):
    kwargs = dict(dict(epoch=EPOCH), **kwargs)
    with pytest.raises(ValueError, match=match):
        lpm.io.write_oem(solved("energy-lgl"), tmp_path / "x.oem", **kwargs)


def test_problems_carry_an_epoch_that_dates_the_oem(tmp_path):
    """The epoch is a static field of the chief's orbit (and of an intercept): canonical UTC,
    kept through a compiled solve, saved and loaded, and the OEM's default epoch; an OEM of
    a problem without one needs epoch=."""
    orbit = ORBIT.replace(epoch="2026-03-01T13:00:00+01:00")         # 12:00 UTC
    assert orbit.epoch == "2026-03-01T12:00:00.000000"
    sol = lpm.solve(lpm.EnergyOptimalTransfer.from_revolutions(orbit, X0, jnp.zeros(6), 0.5),
                    lpm.lgl(9), method="kkt", throw=False)
    assert sol.problem.orbit.epoch == orbit.epoch
    assert lpm.io.load(lpm.io.save(sol, tmp_path / "s.npz")).problem.orbit.epoch == orbit.epoch
    times = np.linspace(0.0, float(sol.duration), 5)
    own = lpm.io.write_oem(sol, tmp_path / "own.oem", times=times).read_text()
    given = lpm.io.write_oem(sol, tmp_path / "given.oem", EPOCH, times=times).read_text()
    data = lambda text: [line for line in text.splitlines() if line[:4] == "2026"]  # noqa
    assert data(own) == data(given) and data(own)[0].startswith("2026-03-01T12:00:00")
    with pytest.raises(ValueError, match="needs an epoch"):
        lpm.io.write_oem(sol.replace(problem=sol.problem.replace(orbit=ORBIT)),
                         tmp_path / "x.oem")
    with pytest.raises(ValueError, match="ISO 8601"):
        ORBIT.replace(epoch="1 March 2026")
    intercept = tan2011.problem(tan2011.recover_elements()[0], revolutions=3, branch="left")
    assert intercept.replace(epoch=EPOCH).epoch == "2026-03-01T12:00:00.000000"
