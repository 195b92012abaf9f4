"""Figures shared by the case reproductions (matplotlib, Agg backend, PNG)."""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import jax  # noqa: E402
import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

from ..orbits import time_from_true_anomaly  # noqa: E402


def _save(fig, path):
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_control(solution, path, title):
    """LVLH control acceleration components and magnitude vs time: interpolant and nodes."""
    f = jnp.linspace(solution.node_f[0], solution.node_f[-1], 1500)
    u = np.asarray(jax.vmap(solution.controls_at_true_anomaly)(f))
    t = np.asarray(time_from_true_anomaly(solution.problem.orbit, f))
    fig, ax = plt.subplots(figsize=(7, 4))
    for k, name in enumerate("xyz"):
        ax.plot(t, u[:, k], label=f"u_{name}")
    ax.plot(t, np.linalg.norm(u, axis=1), "k", lw=1.5, label="|u|")
    ax.plot(solution.node_times, np.linalg.norm(solution.node_controls, axis=1), "k.", ms=4,
            label="|u| at LGL nodes")
    ax.set(xlabel="t (s)", ylabel="acceleration (m/s²)", title=title)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
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
    """Cost and linear-model terminal error against N for both laws."""
    N = [r["N"] for r in rows]
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4))
    ref = rows[-1]["J_kkt"]
    for law in ("stm", "kkt"):
        a1.semilogy(N, [abs(r[f"J_{law}"] - ref) / ref + 1e-17 for r in rows], "o-",
                    label=law.upper())
        a2.semilogy(N, [r[f"terminal_error_linear_{law}"][0] for r in rows], "o-",
                    label=law.upper())
    a1.set(xlabel="N", ylabel=f"|J - J(N={N[-1]})| / J", title="cost convergence")
    a2.set(xlabel="N", ylabel="terminal position error (m)",
           title="linear model, interpolated control")
    for a in (a1, a2):
        a.legend()
        a.grid(alpha=0.3, which="both")
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
        a1.plot(kkt.node_times, kkt.node_controls[:, k], "o", ms=3, color=f"C{k}",
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
