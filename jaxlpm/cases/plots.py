"""Figures shared by the case reproductions (matplotlib, Agg backend, PNG); the control
histories and the convergence plots are drawn by `jaxlpm.plot`."""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .. import plot  # noqa: E402


# Fixed margins (inches) instead of `tight_layout`, which measures every tick label: 0.6-0.8 s
# of the 11 figures of a warm `jaxlpm reproduce mei2010` (issue 21). Wide enough for a label
# and tick labels of up to 8 characters at the default font size.
MARGINS = dict(left=1.0, right=0.25, bottom=0.6, top=0.45)
SPACING = dict(wspace=0.3, hspace=0.25)     # fractions of the mean axes width / height


def _save(fig, path):
    """Lay the figure out with `MARGINS` (a 3D axes keeps its own), write it as PNG, close."""
    w, h = fig.get_size_inches()
    m = MARGINS
    fig.subplots_adjust(left=m["left"] / w, right=1.0 - m["right"] / w, bottom=m["bottom"] / h,
                        top=1.0 - m["top"] / h, **SPACING)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_control(solution, path, title):
    """LVLH control acceleration components and magnitude vs time: interpolant and nodes
    (`jaxlpm.plot.controls`)."""
    fig, ax = plt.subplots(figsize=(7, 4))
    plot.controls(solution, ax=ax, samples=1500, title=title)
    return _save(fig, path)


def plot_relative_motion(ts, xs, path, title, time_label="t (s)"):
    """Relative position and velocity components (LVLH) vs time."""
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    for k, name in enumerate("xyz"):
        a1.plot(ts, xs[:, k], label=name)
        a2.plot(ts, xs[:, 3 + k], label=f"v{name}")
    a1.set(ylabel="position (m)", title=title)
    a2.set(xlabel=time_label, ylabel="velocity (m/s)")
    for a in (a1, a2):
        a.legend(fontsize=8)
        a.grid(alpha=0.3)
    return _save(fig, path)


def plot_convergence(rows, path):
    """Cost and linear-model terminal error against N for both laws (`jaxlpm.plot.convergence`:
    the rows that did not end SUCCESS are marked apart, not joined)."""
    N = np.array([r["N"] for r in rows])
    laws = ("stm", "kkt")
    status = {law.upper(): [r.get(f"status_{law}", "SUCCESS") for r in rows] for law in laws}
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4))
    ref = rows[-1]["J_kkt"]          # the finest grid is the reference: not plotted against itself
    plot.convergence(N[:-1], {law.upper(): [abs(r[f"J_{law}"] - ref) / ref for r in rows[:-1]]
                              for law in laws}, {k: v[:-1] for k, v in status.items()}, ax=a1,
                     xlabel="N", ylabel=f"|J - J(N={N[-1]})| / J", title="cost convergence")
    plot.convergence(N, {law.upper(): [r[f"terminal_error_linear_{law}"][0] for r in rows]
                         for law in laws}, status, ax=a2, xlabel="N",
                     ylabel="terminal position error (m)",
                     title="linear model, interpolated control")
    return _save(fig, path)


def plot_control_history(ts, us, path, title, time_label="t (s)"):
    """LVLH control acceleration components and magnitude vs time (sampled values)."""
    fig, ax = plt.subplots(figsize=(7, 4))
    for k, name in enumerate("xyz"):
        ax.plot(ts, us[:, k], label=f"u_{name}")
    ax.plot(ts, np.linalg.norm(us, axis=1), "k", lw=1.5, label="|u|")
    ax.set(xlabel=time_label, ylabel="acceleration (m/s²)", title=title)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return _save(fig, path)


def plot_terminal_weight_limit(link, ts, kkt, controls, path):
    """Finite-horizon LQ law against the KKT law: the hard-constraint law's control history
    (sampled at ts) through the KKT law's nodal controls, and the gap against the terminal
    weight sigma (approaching the hard constraint)."""
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4))
    for k, name in enumerate("xyz"):
        a1.plot(ts, controls[:, k], "-", lw=1, color=f"C{k}", label=f"LQ sweep u_{name}")
        a1.plot(kkt.times, kkt.node_controls[:, k], "o", ms=3, color=f"C{k}",
                label=f"KKT law u_{name}")
    a1.set(xlabel="t (s)", ylabel="acceleration (m/s²)",
           title="hard terminal constraint: LQ sweep and KKT law")
    a1.legend(fontsize=7, ncol=2)
    rows = link["terminal_weight"]
    sig = [r["sigma"] for r in rows]
    a2.loglog(sig, [r["control_rel_diff_vs_kkt"] for r in rows], "o-",
              label="max |u - u_KKT| / max |u_KKT|")
    a2.loglog(sig, [r["terminal_miss"][0] for r in rows], "s-", label="terminal miss (m)")
    a2.axhline(link["control_rel_diff_at_nodes"], color="k", ls="--", lw=1,
               label="hard constraint vs KKT")
    a2.set(xlabel="terminal weight sigma (nondimensional)", title="sigma -> inf limit")
    for a in (a1, a2):
        a.grid(alpha=0.3, which="both")
    a2.legend(fontsize=8)
    return _save(fig, path)


def plot_direction_history(ts, directions, node_t, node_directions, names, path, title):
    """Thrust direction components vs time: interpolant (lines) and nodal values (dots)."""
    fig, ax = plt.subplots(figsize=(7, 4))
    for k, name in enumerate(names):
        line, = ax.plot(ts, directions[:, k], label=f"u {name}")
        ax.plot(node_t, node_directions[:, k], ".", ms=3, color=line.get_color())
    ax.set(xlabel="t (s)", ylabel="thrust direction (unit vector)", title=title)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return _save(fig, path)


def plot_release_3d(transfer, coast, path, title):
    """3D relative trajectory: the powered transfer and the coast after it (positions, m)."""
    fig = plt.figure(figsize=(7, 6))
    ax = fig.add_subplot(projection="3d")
    ax.plot(*coast[:, :3].T, lw=0.6, color="C0", label="coast (fly-around)")
    ax.plot(*transfer[:, :3].T, lw=2.0, color="C3", label="powered release")
    ax.scatter([0], [0], [0], color="k", s=15, label="chief")
    ax.set(xlabel="x (m)", ylabel="y (m)", zlabel="z (m)", title=title)
    ax.legend(fontsize=8)
    return _save(fig, path)


def plot_mesh_study(convergence, schemes, path):
    """Minimum time against the number of points (one scheme) and across schemes: |t_f(K) -
    t_f*| against the grid-independent reference (rows' "tf_error"), and the flown terminal
    miss."""
    K = np.array([r["K"] for r in convergence])
    status = [r["status"] for r in convergence]
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4))
    plot.convergence(K, {convergence[0].get("scheme", "LG"): [abs(r["tf_error"]) + 1e-16
                                                              for r in convergence]},
                     status, ax=a1, xlabel="K (points)", ylabel="|t_f - t_f*| (s)",
                     title="minimum time against the shooting optimum t_f*")
    for r in schemes:
        a1.semilogy([r["K"]], [abs(r["tf_error"]) + 1e-16], "s", label=f"{r['scheme']} K = "
                    f"{r['K']}")
    a1.legend(fontsize=8)
    plot.convergence(K, {"position (m)": [r["terminal_miss"][0] for r in convergence],
                         "velocity (m/s)": [r["terminal_miss"][1] for r in convergence]},
                     status, ax=a2, xlabel="K (points)",
                     title="terminal miss of the flown direction (CW)")
    return _save(fig, path)
