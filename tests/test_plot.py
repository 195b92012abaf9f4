"""jaxlpm.plot: each helper draws what its docstring says (the sampled states and controls of
the solution in LVLH, the chief, the keep-out zone, the nodes), and members that did not end
SUCCESS are greyed, hatched or left out and counted, never coloured as results. One tiny
transfer on lgl(9) (and a batch of three), Agg backend."""

import subprocess
import sys

import matplotlib

matplotlib.use("Agg")
import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.collections import PatchCollection, QuadMesh  # noqa: E402
from matplotlib.colors import to_rgba  # noqa: E402
from matplotlib.patches import Ellipse  # noqa: E402

import jaxlpm as lpm  # noqa: E402

LOOSE = lpm.Tolerance(position=1e12, velocity=1e9, path=1e9)   # lgl(9) resolves nothing
ORBIT = lpm.KeplerOrbit(a=9500e3, e=0.1)
X0 = jnp.array([10e3, 10e3, 500.0, 4.0, -23.485, 0.0])


def problem(e=0.1):
    return lpm.EnergyOptimalTransfer.from_revolutions(ORBIT.replace(e=e), X0, jnp.zeros(6), 1.0)


@pytest.fixture(scope="module")
def sol():
    s = lpm.solve(problem(), lpm.lgl(9), tolerance=LOOSE, throw=False)
    assert int(s.status) == lpm.Status.SUCCESS
    return s


@pytest.fixture(scope="module")
def batch():
    """Three members, the middle one marked INACCURATE (as a stricter tolerance would)."""
    b = jax.vmap(lambda e: lpm.solve(problem(e), lpm.lgl(9), tolerance=LOOSE))(
        jnp.array([0.0, 0.1, 0.2]))
    return b.replace(status=b.status.at[1].set(lpm.Status.INACCURATE))


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


def legend_texts(ax):
    return [t.get_text() for t in ax.get_legend().get_texts()]


def test_import_jaxlpm_does_not_import_matplotlib():
    code = "import sys, jaxlpm; print('matplotlib' in sys.modules, hasattr(jaxlpm, 'plot'))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.split() == ["False", "True"]


def test_trajectory_lvlh_planes_chief_nodes_and_keep_out(sol):
    zone = ([0.0, 500.0, 0.0], [300.0, 600.0, 200.0])            # an ellipsoid, m
    axes = lpm.plot.trajectory(sol, keep_out=zone, samples=50, label="plan")
    assert len(axes) == 2
    (a1, a2) = axes
    assert (a1.get_xlabel(), a1.get_ylabel()) == ("y along-track (km)", "x radial (km)")
    assert (a2.get_xlabel(), a2.get_ylabel()) == ("y along-track (km)", "z normal (km)")
    path = next(ln for ln in a1.get_lines() if ln.get_label() == "plan")
    r = np.asarray(sol.states(np.linspace(0.0, float(sol.duration), 50)))[:, :3] / 1e3
    np.testing.assert_allclose(path.get_xdata(), r[:, 1], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(path.get_ydata(), r[:, 0], rtol=1e-12, atol=1e-12)
    nodes = [ln for ln in a1.get_lines() if ln.get_marker() == "." and len(ln.get_xdata()) == 9]
    np.testing.assert_allclose(nodes[0].get_xdata(), np.asarray(sol.node_states)[:, 1] / 1e3)
    ellipse, = [p for p in a1.patches if isinstance(p, Ellipse)]
    assert ellipse.center == pytest.approx((0.5, 0.0))                 # (y, x) in km
    assert (ellipse.width, ellipse.height) == pytest.approx((1.2, 0.6))  # 2 * (600, 300) m
    ellipse2, = [p for p in a2.patches if isinstance(p, Ellipse)]
    assert (ellipse2.width, ellipse2.height) == pytest.approx((1.2, 0.4))
    assert {"plan", "chief (origin)", "keep-out zone"} <= set(legend_texts(a1))

    # overlaying a flight keeps one chief, one zone and the unit
    flight = lpm.verify.fly(sol)
    axes = lpm.plot.trajectory(flight, ax=axes, keep_out=zone, label="flown")
    assert sum(ln.get_gid() == "jaxlpm-chief" for ln in axes[0].get_lines()) == 1
    assert len([p for p in axes[0].patches if isinstance(p, Ellipse)]) == 1
    assert legend_texts(axes[0]).count("keep-out zone") == 1
    flown = next(ln for ln in axes[0].get_lines() if ln.get_label() == "flown")
    np.testing.assert_allclose(flown.get_xdata(), np.asarray(flight.states)[:, 1] / 1e3)

    ax, = lpm.plot.trajectory(sol, planes="xz", unit="m", nodes=False,
                              keep_out=[zone, ([0.0, 0.0, 0.0], 100.0)])     # two zones
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("x radial (m)", "z normal (m)")
    sphere = [p for p in ax.patches if isinstance(p, Ellipse)][1]
    assert (sphere.width, sphere.height) == pytest.approx((200.0, 200.0))


def test_trajectory_greys_the_members_that_did_not_succeed(batch):
    a1, _ = lpm.plot.trajectory(batch, samples=20)
    paths = [ln for ln in a1.get_lines() if len(ln.get_xdata()) == 20]
    grey = [ln for ln in paths if to_rgba(ln.get_color()) == to_rgba(lpm.plot.GREY)]
    assert len(paths) == 3 and len(grey) == 1
    assert grey[0].get_linestyle() == "--"
    r1 = np.asarray(jax.tree_util.tree_map(lambda x: x[1], batch).states(
        np.linspace(0.0, float(batch.duration[1]), 20)))
    np.testing.assert_allclose(grey[0].get_xdata(), r1[:, 1] / 1e3, rtol=1e-12)
    assert "not SUCCESS: 1 of 3 (1 INACCURATE)" in legend_texts(a1)
    nodes = [ln for ln in a1.get_lines() if ln.get_marker() == "."]
    assert len(nodes) == 3
    np.testing.assert_allclose(nodes[1].get_xdata(), np.asarray(batch.node_states)[1, :, 1] / 1e3)


def test_controls_components_and_magnitude(sol, batch):
    ax = lpm.plot.controls(sol, samples=40, time_unit="min")
    t = np.linspace(0.0, float(sol.duration), 40)
    u = np.asarray(sol.controls(t))
    lines = {ln.get_label(): ln for ln in ax.get_lines()}
    for k, name in enumerate("xyz"):
        np.testing.assert_allclose(lines[f"u_{name}"].get_ydata(), u[:, k], rtol=1e-12,
                                   atol=1e-15)
    np.testing.assert_allclose(lines["|u|"].get_xdata(), t / 60.0)
    np.testing.assert_allclose(lines["|u|"].get_ydata(), np.linalg.norm(u, axis=1), rtol=1e-12)
    np.testing.assert_allclose(lines["|u| at the collocation points"].get_ydata(),
                               np.linalg.norm(np.asarray(sol.node_controls), axis=1))
    assert ax.get_xlabel() == "t (min)" and ax.get_ylabel() == "acceleration, LVLH (m/s²)"

    ax = lpm.plot.controls(batch, samples=30)
    members = [ln for ln in ax.get_lines() if len(ln.get_xdata()) == 30]
    assert len(members) == 3
    assert sum(to_rgba(ln.get_color()) == to_rgba(lpm.plot.GREY) for ln in members) == 1
    assert "not SUCCESS: 1 of 3 (1 INACCURATE)" in legend_texts(ax)


def test_convergence_joins_only_success():
    points = np.array([9, 17, 33, 65])
    ax = lpm.plot.convergence(points, {"error": [1e-1, 1e-3, 1e-7, 0.0]},
                              {"error": ["MAX_ITERATIONS", "SUCCESS", "SUCCESS", "SUCCESS"]},
                              ylabel="m")
    joined, = [ln for ln in ax.get_lines() if ln.get_linestyle() == "-"]
    assert list(joined.get_xdata()) == [17, 33]                  # 65: 0 has no place on a log
    cross, = [ln for ln in ax.get_lines() if ln.get_marker() == "x"]
    assert list(cross.get_xdata()) == [9] and cross.get_label() == "error: MAX_ITERATIONS"
    assert ax.get_yscale() == "log" and ax.get_xscale() == "linear"
    ax = lpm.plot.convergence(points, [1.0, 0.1, 0.01, 0.001], logx=True)
    assert ax.get_xscale() == "log" and len(ax.get_lines()[0].get_xdata()) == 4
    with pytest.raises(ValueError, match="shape"):
        lpm.plot.convergence(points, [1.0, 2.0])


def test_sweep_map_greys_out_non_success_cells():
    e, rev = np.meshgrid(np.linspace(0.0, 0.6, 4), np.linspace(1.0, 4.0, 3))
    values = 1.0 + e + rev
    status = np.where(e > 0.5, lpm.Status.INACCURATE, lpm.Status.SUCCESS)
    status[0, 0] = lpm.Status.MAX_ITERATIONS
    values[status != lpm.Status.SUCCESS] = 1e6                   # never on the colour scale
    ax = lpm.plot.sweep_map(e, rev, values, status, colorbar_label="J")
    mesh, = [c for c in ax.collections if isinstance(c, QuadMesh)]
    z = mesh.get_array()
    assert z.shape == (3, 4) and int(np.ma.count_masked(z)) == 4
    np.testing.assert_allclose(z[~z.mask], values[status == lpm.Status.SUCCESS])
    assert (mesh.norm.vmin, mesh.norm.vmax) == (values[status == 0].min(),
                                                values[status == 0].max())
    grey, = [c for c in ax.collections if isinstance(c, PatchCollection)]
    assert len(grey.get_paths()) == 4 and grey.get_hatch() == "//"
    assert legend_texts(ax) == ["not SUCCESS: 4 of 12 (1 MAX_ITERATIONS, 3 INACCURATE)"]
    assert len(ax.figure.axes) == 2                              # the colour bar

    rng = np.random.default_rng(0)                               # scattered members
    x, y = rng.random(10), rng.random(10)
    ax = lpm.plot.sweep_map(x, y, rng.random(10) + 1.0, ["SUCCESS"] * 8 + ["STALLED"] * 2,
                            log=True)
    coloured, crosses = ax.collections[:2]
    assert len(coloured.get_offsets()) == 8 and len(crosses.get_offsets()) == 2
    np.testing.assert_allclose(crosses.get_offsets(), np.c_[x, y][8:])
    assert legend_texts(ax) == ["not SUCCESS: 2 of 10 (2 STALLED)"]


def test_histogram_takes_success_members_only():
    values = np.r_[np.linspace(1.0, 2.0, 30), [1e3, np.nan]]
    status = [0] * 30 + [lpm.Status.INACCURATE, lpm.Status.NONFINITE]
    ax = lpm.plot.histogram(values, status, bins=5, xlabel="delta-v (m/s)")
    assert sum(p.get_height() for p in ax.patches) == 30
    assert max(p.get_x() + p.get_width() for p in ax.patches) == pytest.approx(2.0)
    texts = legend_texts(ax)
    assert "SUCCESS: 30 of 32" in texts and "mean 1.5" in texts
    assert "not SUCCESS: 2 of 32 (1 NONFINITE, 1 INACCURATE) (left out)" in texts


def test_bad_arguments_say_what_is_allowed(sol):
    with pytest.raises(ValueError, match="plane"):
        lpm.plot.trajectory(sol, planes=("xx",))
    with pytest.raises(ValueError, match="radius"):
        lpm.plot.trajectory(sol, keep_out=([0.0, 0.0, 0.0], -5.0))
    with pytest.raises(ValueError, match="unit"):
        lpm.plot.trajectory(sol, unit="mi")
    with pytest.raises(ValueError, match="status name"):
        lpm.plot.histogram([1.0], ["DONE"])
    with pytest.raises(ValueError, match="Solution"):
        lpm.plot.controls(np.zeros(3))


def test_save_writes_and_closes(tmp_path, sol):
    ax = lpm.plot.controls(sol, samples=20)
    path = lpm.plot.save(ax, tmp_path / "sub" / "u.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert ax.figure.number not in plt.get_fignums()
