"""Jiang, Li, Zhang & Tan (2011): continuous-thrust optimal rendezvous by the algebraic Riccati
equation (Manned Spaceflight 2011(3), 7-10).

The paper: HCW relative motion (its frame: x radial, y along-track, z orbit normal - ours),
the infinite-horizon quadratic cost int (x^T Q x + u^T R u) dt, the gain u = -R^-1 B^T P x
with P from the ordered real Schur form of the Hamiltonian. The stored text stops after the
method: no orbit, weights, initial state or results survive, so the case is ours
(docs/jiang2011.md):

- chief: circular, altitude 343 km (the 2011 Tiangong-1 / Shenzhou-8 rendezvous orbit that is
  the paper's context), a = R_E + 343 km, mu = MU_EARTH;
- chaser at the start of the close-range phase: 1 km below, 5 km behind, 300 m out of plane,
  on the natural coelliptic drift vy = 1.5 n |x| (LVLH [x, y, z, vx, vy, vz] in m, m/s);
- weights by Bryson's rule: Q = diag(1/(1 km)^2 x 3, 1/(1 m/s)^2 x 3), R = I/(1 mm/s^2)^2;
- flown for 6 chief periods (the paper's finite-time evaluation of the cost).

Solved through the public API: `solve(LQRTransfer(..., terminal="infinite"))` (the CARE's
stationary law flown by the exact Riccati sweep), and the solution flown independently by
`verify.fly` on the linear (HCW) model.

Cross-check with the pseudospectral laws: with Q = 0, R = I the finite-horizon regulator with
the hard terminal constraint (`terminal="hard"`) is Mei's energy-optimal transfer (the KKT law,
`method="kkt"`, with e = 0); the same chief and initial state, to the origin in one period,
N = 32 (33 LGL points); `terminal="weight"` with S_T = sigma I (solver's units) approaches it.
"""

import time

import jax.numpy as jnp
import numpy as np

from ..collocation import lgl
from ..constants import MU_EARTH, R_EARTH
from ..dynamics import hcw_matrix
from ..orbits import KeplerOrbit
from ..problems import EnergyOptimalTransfer, LQRTransfer
from ..solvers import solve
from ..verify import fly

NAME = "jiang2011"
TITLE = "Jiang, Li, Zhang & Tan 2011: continuous-thrust LQR rendezvous by the Riccati equation"

ALTITUDE = 343e3                          # m
A_CHIEF = R_EARTH + ALTITUDE
REVOLUTIONS = 6.0
POSITION_SCALE, VELOCITY_SCALE, ACCEL_SCALE = 1000.0, 1.0, 1e-3   # Bryson's rule (m, m/s, m/s^2)
N_KKT = 32                                # LGL N for the cross-check (33 nodes): one period
                                          # at e = 0 is resolved to rounding (N = 64: no better)
SIGMAS = (1e0, 1e2, 1e4, 1e6, 1e8)        # nondimensional terminal weights toward the hard limit
N_OUT = 601                               # output times for the figures

PUBLISHED = {
    "source": "Jiang Y., Li H., Zhang Z., Tan W., Manned Spaceflight 2011(3), 7-10, §2-3",
    "method": "infinite-horizon LQR on the CW equations; ARE solved by the ordered real Schur "
              "form of the Hamiltonian (Laub 1979)",
    "numbers": "none: the stored text is truncated after the method (no case, no results)",
}


def mean_motion() -> float:
    """n = sqrt(mu / a^3) of the chief, rad/s."""
    return float(np.sqrt(MU_EARTH / A_CHIEF**3))


def chief() -> KeplerOrbit:
    """The chief's circular orbit (t = 0 at its epoch)."""
    return KeplerOrbit(a=jnp.asarray(A_CHIEF), e=jnp.asarray(0.0))


def weights():
    """(Q, R) of the case, SI: Bryson's rule with 1 km, 1 m/s and 1 mm/s^2."""
    Q = np.diag([POSITION_SCALE**-2] * 3 + [VELOCITY_SCALE**-2] * 3)
    R = np.eye(3) * ACCEL_SCALE**-2
    return Q, R


def initial_state():
    """Chaser LVLH state (m, m/s): 1 km below, 5 km behind, 300 m out of plane, drifting."""
    return np.array([-1000.0, -5000.0, 300.0, 0.0, 1.5 * mean_motion() * 1000.0, 0.0])


def _rel(a, b):
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b))) / np.max(np.abs(np.asarray(b))))


def kkt_link(log=print):
    """Hard-constraint and terminal-weight limits of the finite-horizon LQ law against the KKT
    law, on the same HCW transfer (Q = 0, R = I, one period, to the origin)."""
    n = mean_motion()
    T = 2.0 * np.pi / n
    x0 = initial_state()
    orbit = chief()
    prob = EnergyOptimalTransfer(orbit, jnp.asarray(x0), jnp.zeros(6), jnp.asarray(T))
    t = time.perf_counter()
    grid = lgl(N_KKT + 1)
    kkt = solve(prob, grid, method="kkt", throw=False)
    if not bool(kkt.success):
        raise RuntimeError(f"the KKT law failed: {kkt.message}")
    nodes = np.asarray(kkt.times)
    Q0, R1 = np.zeros((6, 6)), np.eye(3)
    # S_T = sigma I in the solver's units: (c / n) diag(1, 1, 1, 1/n^2, 1/n^2, 1/n^2), c = n^4
    unit = n**3 * np.diag([1.0, 1.0, 1.0, n**-2, n**-2, n**-2])
    hard = solve(LQRTransfer(orbit, x0, T, Q0, R1, terminal="hard"))
    soft = [solve(LQRTransfer(orbit, x0, T, Q0, R1, s * unit, terminal="weight"))
            for s in SIGMAS]
    log(f"KKT law (N = {N_KKT}) and {1 + len(SIGMAS)} finite-horizon sweeps in "
        f"{time.perf_counter() - t:.1f} s")
    J = float(kkt.cost)
    u_hard, x_hard = hard.controls(nodes), hard.states(nodes)
    soft_u = [f.controls(nodes) for f in soft]
    miss = lambda f: [float(np.linalg.norm(f.node_states[-1, :3])),
                      float(np.linalg.norm(f.node_states[-1, 3:]))]
    ts = np.linspace(0.0, T, N_OUT - nodes.size)          # for the figure
    return {
        "problem": "HCW (e = 0), same chief and x0, to the origin at rest in one period "
                   f"({T:.3f} s); Q = 0, R = I; J = 1/2 int |u|^2 dt (m^2/s^3)",
        "N": N_KKT,
        "J_kkt": J,
        "J_lq_hard": float(hard.cost),
        "J_rel_diff": abs(float(hard.cost) - J) / J,
        "control_rel_diff_at_nodes": _rel(u_hard, kkt.node_controls),
        "state_rel_diff_at_nodes": _rel(x_hard, kkt.node_states),
        "lq_hard_terminal_miss": miss(hard),
        "terminal_weight": [
            {"sigma": s, "J": float(f.cost), "terminal_miss": miss(f),
             "control_rel_diff_vs_kkt": _rel(u, kkt.node_controls)}
            for s, f, u in zip(SIGMAS, soft, soft_u)],
        "sigma_units": "S_T = sigma (n^3 diag(1, 1, 1, 1/n^2, 1/n^2, 1/n^2)) in SI, i.e. "
                       "sigma I in the solver's units (time 1/n, lengths m, R = I)",
    }, (ts, kkt, hard.controls(ts))


def compute(log=print):
    """Design the regulator, fly it for 6 periods, cross-check with the KKT law. Returns
    (ts, the `Solution`, the KKT link's figure data, the JSON-ready dict)."""
    n = mean_motion()
    Q, R = weights()
    x0 = initial_state()
    T = REVOLUTIONS * 2.0 * np.pi / n
    ts = np.linspace(0.0, T, N_OUT)
    t = time.perf_counter()
    sol = solve(LQRTransfer(chief(), x0, T, Q, R, terminal="infinite"))
    stats = sol.stats
    log(f"CARE ({int(stats['care_iterations'])} sign iterations) and the 6-period sweep in "
        f"{time.perf_counter() - t:.1f} s")
    t = time.perf_counter()
    flown = fly(sol)
    log(f"flown on the linear model in {time.perf_counter() - t:.1f} s")
    A = np.asarray(hcw_matrix(n))
    B = np.vstack([np.zeros((3, 3)), np.eye(3)])
    K = np.asarray(stats["K0"])
    eig = np.linalg.eigvals(A - B @ K)
    link, link_data = kkt_link(log)
    u = np.asarray(sol.controls(ts))
    computed = {
        "care_residual": float(stats["care_residual"]),
        "care_residual_definition": "|A^T P + P A - P B R^-1 B^T P + Q|_F / |Q|_F in the "
                                    "solver's nondimensional scaling (time 1/n, lengths m)",
        "closed_loop_max_real_eig": float(eig.real.max()),
        "closed_loop_max_real_eig_units": "1/s",
        "closed_loop_eigenvalues_over_n": [[float(z.real), float(z.imag)] for z in
                                           sorted(eig / n, key=lambda z: (z.real, z.imag))],
        "dv_total": float(sol.delta_v),
        "dv_units": "m/s (int |u| dt over 6 chief periods)",
        "final_state": [float(v) for v in np.asarray(sol.node_states[-1])],
        "final_state_units": "LVLH [x, y, z, vx, vy, vz], m and m/s, after 6 chief periods",
        "flown_final_state": [float(v) for v in np.asarray(flown.states[-1])],
        "flown_plan_error": [float(v) for v in np.asarray(flown.plan_error)],
        "flown_units": "the solution's control u(t) flown open loop on the linear (HCW) model "
                       "by verify.fly (Dopri8, rtol = atol = 1e-12 on scaled states): final "
                       "LVLH state (m, m/s) and the largest |flown - planned| [m, m/s] over "
                       f"{flown.times.shape[0]} uniform times",
        "peak_acceleration": float(np.linalg.norm(u, axis=1).max()),
        "cost_6_periods": float(sol.cost),
        "cost_infinite_horizon": float(stats["predicted_cost"]),
        "cost_units": "1/2 int (x^T Q x + u^T R u) dt (+ 1/2 x(T)^T P x(T)), s (Q, R as below)",
        "sign_iterations": int(stats["care_iterations"]),
        "P": np.asarray(stats["P0"]).tolist(),
        "K": K.tolist(),
        "K_units": "m/s^2 per [m, m, m, m/s, m/s, m/s]",
        "kkt_link": link,
        "case": {
            "chief": f"circular, altitude {ALTITUDE / 1e3:.0f} km, a = {A_CHIEF:.1f} m, "
                     f"n = {n:.10e} rad/s, period = {2 * np.pi / n:.3f} s",
            "x0": x0.tolist(),
            "Q_diag": np.diag(Q).tolist(),
            "R_diag": np.diag(R).tolist(),
            "duration_s": T,
            "frame": "LVLH: x radial outward, y along-track, z orbit normal",
        },
    }
    return ts, sol, link_data, computed


NOTES = [
    "The paper's text is truncated after its method: the case (chief, Q, R, x0) is ours and "
    "there are no published numbers to compare with (docs/jiang2011.md).",
    "The ARE is solved by the matrix sign function of the Hamiltonian (not the paper's ordered "
    "Schur form, which JAX lacks on most backends), one Newton-Kleinman step, and agrees with "
    "scipy.linalg.solve_continuous_are (tests/test_riccati.py).",
    "Link to the pseudospectral laws: the finite-horizon regulator with Q = 0, R = I and the "
    "hard terminal constraint is the energy-optimal transfer that Mei's KKT law discretises; "
    "with a terminal weight sigma the controls approach it as 1/sigma (kkt_link).",
]


def report(computed, log=print):
    c, k = computed, computed["kkt_link"]
    log(f"\n{TITLE}\n(no published numbers: the stored text is truncated)\n")
    rows = [
        ("CARE relative residual (nondimensional)", f"{c['care_residual']:.3e}"),
        ("closed-loop max Re(eig) (1/s)", f"{c['closed_loop_max_real_eig']:.6e}"),
        ("  ... in units of n", f"{c['closed_loop_eigenvalues_over_n'][-1][0]:.6f}"),
        ("delta-v over 6 periods (m/s)", f"{c['dv_total']:.6f}"),
        ("peak |u| (m/s^2)", f"{c['peak_acceleration']:.6e}"),
        ("final position |r| (m)", f"{np.linalg.norm(c['final_state'][:3]):.3e}"),
        ("final velocity |v| (m/s)", f"{np.linalg.norm(c['final_state'][3:]):.3e}"),
        ("flown on HCW: max |r_flown - r_plan| (m)", f"{c['flown_plan_error'][0]:.3e}"),
        ("KKT law J (m^2/s^3), one period", f"{k['J_kkt']:.12e}"),
        ("hard-constraint LQ sweep J", f"{k['J_lq_hard']:.12e}"),
        ("  max |u_LQ - u_KKT| / max |u_KKT| at nodes", f"{k['control_rel_diff_at_nodes']:.2e}"),
    ]
    for name, val in rows:
        log(f"{name:<48}{val:>22}")
    log(f"\n{'sigma':>8}{'J (m^2/s^3)':>22}{'miss (m)':>12}{'u rel diff vs KKT':>20}")
    for r in k["terminal_weight"]:
        log(f"{r['sigma']:>8.0e}{r['J']:>22.12e}{r['terminal_miss'][0]:>12.3e}"
            f"{r['control_rel_diff_vs_kkt']:>20.3e}")
    log("")
    for note in NOTES:
        log(f"- {note}")


def figures(ts, sol, link_data, computed, out_dir):
    """State and control histories of the 6-period flight (the `Solution` at ts); the KKT
    cross-check."""
    from .plots import plot_control_history, plot_relative_motion, plot_terminal_weight_limit

    period = 2.0 * np.pi / mean_motion()
    t_rev = np.asarray(ts) / period
    return [
        plot_relative_motion(t_rev, np.asarray(sol.states(ts)), out_dir / "fig1_states.png",
                             "LQR rendezvous: LVLH state (t in chief periods)",
                             time_label="t (chief periods)"),
        plot_control_history(t_rev, np.asarray(sol.controls(ts)), out_dir / "fig2_control.png",
                             "LQR rendezvous: control acceleration",
                             time_label="t (chief periods)"),
        plot_terminal_weight_limit(computed["kkt_link"], *link_data,
                                   out_dir / "fig3_kkt_link.png"),
    ]


def reproduce(out_dir, log=print):
    """Run the case: compute, print, draw. Returns the JSON-ready result dict."""
    ts, sol, link_data, computed = compute(log)
    report(computed, log)
    out_dir.mkdir(parents=True, exist_ok=True)
    for path in figures(ts, sol, link_data, computed, out_dir):
        log(f"wrote {path}")
    return {"schema_version": 1, "case": NAME, "published": PUBLISHED, "computed": computed,
            "notes": NOTES}
