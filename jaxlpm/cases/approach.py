"""A safety-constrained V-bar approach and docking on an eccentric chief under J2: jaxlpm's own
case (issue 22), not a paper's.

The target flies a = 7000 km, e = 0.05, i = 51.6 deg (perigee at the start of the approach); the
chaser (500 kg, 0.5 N, Isp 220 s: a small hydrazine thruster set) holds on V-bar 1 km behind it
and docks in 0.75 of an orbital period at a port 5 m behind the target's centre, arriving along
+y at 3 cm/s. LVLH frame about the target (x radial outward, y along-track, z orbit normal).
Safety constraints (Fehse 2003, "Automated rendezvous and docking of spacecraft", ch. 4-5):

  keep-out sphere      200 m about the target, held over the first 60 % of the transfer;
  approach cone        within 300 m of the port, the line of sight stays within 10 deg of -V-bar;
  speed vs range       |v| <= 0.05 m/s + 0.002 /s x (range to the port);
  passive abort safety the free drift from any point of the first half of the transfer stays
                       outside a 100 m sphere for one orbital period (linear model).

Solved on the J2 model twice: energy-optimal (min 1/2 int |u|^2 dt, augmented Lagrangian with
mesh refinement over a ladder of LGR meshes) and fuel-optimal (min int |u| dt with |u| <= u_max,
the energy-to-fuel continuation inside the augmented Lagrangian,
`jaxlpm.solvers.fuel_constrained`, down to eps = 0.01, on 16 uniform LGR segments); each
constraint's largest violation is checked densely between the nodes in SI, and the same two
transfers without the safety constraints give the price of safety.
"""

import sys
import time
from concurrent.futures import ThreadPoolExecutor

import jax.numpy as jnp
import numpy as np

from ..constants import J2_EARTH, MU_EARTH, R_EARTH
from ..orbits import KeplerOrbit
from ..problems import EnergyOptimalTransfer, safety
from ..problems.fuel_optimal import FuelOptimalTransfer
from ..solution.accuracy import DEFAULT_TOLERANCE, Judge
from ..solvers.api import solve
from ..solvers.energy_optimal import refine_transfer
from ..solvers.fuel_constrained import FuelALOptions
from ..solvers.fuel_optimal import burn_arcs
from ..solvers.fuel_optimal import refine_transfer as refine_fuel
from ..solvers.refine import MeshLadder
from ..status import Status
from .result import finish, prefetch_case

NAME = "approach"
TITLE = ("jaxlpm approach: a safety-constrained V-bar approach and docking on an eccentric "
         "chief under J2, energy- and fuel-optimal")

A, E, INCLINATION = 7000e3, 0.05, np.radians(51.6)     # m, -, rad
MASS, THRUST_MAX, ISP = 500.0, 0.5, 220.0               # kg, N, s
HOLD = (0.0, -1000.0, 0.0, 0.0, 0.0, 0.0)               # V-bar hold (m, m/s)
PORT = (0.0, -5.0, 0.0)                                 # docking port (m)
ARRIVAL = (0.0, -5.0, 0.0, 0.0, 0.03, 0.0)              # at the port, closing at 3 cm/s
REVOLUTIONS = 0.75
KEEP_OUT_RADIUS, KEEP_OUT_UNTIL = 200.0, 0.6            # m, fraction of the transfer
CONE_HALF_ANGLE, CONE_RANGE = np.radians(10.0), 300.0   # rad, m
SPEED_V0, SPEED_K = 0.05, 0.002                         # m/s, 1/s
ABORT_RADIUS, ABORT_UNTIL, ABORT_SAMPLES = 100.0, 0.5, 16   # m, fraction, drift samples
ENERGY_LADDER = MeshLadder(((16, 8), (24, 8), (32, 8)))
# the fuel family's augmented-Lagrangian settings for the energy-optimal solve too: with the
# safety family's default tol_path (1e-9) its outer loop did not converge on 16 x 8 points
# (30 outer iterations, the abort-safety drift 96 m inside its sphere); with the fuel family's
# 1e-7 (until 2026-12-07) it converged in 13, and with its 1e-6 (5e-7 of a zone's radius) too
ENERGY_OPTIONS = FuelALOptions().al
FUEL_SEGMENTS, FUEL_POINTS = 16, 8
# the continuation stops at eps = 0.01 (delta-v within eps / (1 - eps) = 1 % of the mesh's fuel
# optimum by the smoothing bound). The family's default schedule's last step (3e-3) reached 40
# outer iterations (MAX_ITERATIONS) until the penalty handed on between steps was capped
# (`FuelALOptions.rho_carry`); it now converges in 24, to a delta-v 4.7e-5 relative below
# eps = 0.01's, on a mesh that stays INACCURATE either way, so the case keeps its shorter run
# (measured 2026-12-07 by experiments/approach_fuel_meshes.py --segments 16
# --eps 1,0.3,0.1,0.03,0.01,0.003, docs/approach.md)
FUEL_OPTIONS = FuelALOptions(eps=(1.0, 0.3, 0.1, 0.03, 0.01))
CONSTRAINT_NAMES = ("keep_out_m", "approach_cone_m", "speed_limit_mps", "passive_safety_m")

PUBLISHED = {
    "source": "none: jaxlpm's own case (issue 22); the constraint types and numbers follow "
              "Fehse 2003, Automated Rendezvous and Docking of Spacecraft, ch. 4-5",
}


def orbit() -> KeplerOrbit:
    return KeplerOrbit(a=jnp.asarray(A), e=jnp.asarray(E), i=jnp.asarray(INCLINATION))


def constraints(duration):
    """The four safety constraints (module docstring), in SI, LVLH about the target."""
    period = float(orbit().period)
    return (safety.KeepOutEllipsoid(semi_axes=jnp.full(3, KEEP_OUT_RADIUS),
                                    window=jnp.array([0.0, KEEP_OUT_UNTIL * duration])),
            safety.ApproachCone(axis=jnp.array([0.0, -1.0, 0.0]), half_angle=CONE_HALF_ANGLE,
                                range=CONE_RANGE, port=jnp.asarray(PORT)),
            safety.SpeedLimit(v0=SPEED_V0, k=SPEED_K, centre=jnp.asarray(PORT)),
            safety.PassiveSafety(semi_axes=jnp.full(3, ABORT_RADIUS), horizon=period,
                                 window=jnp.array([0.0, ABORT_UNTIL * duration]),
                                 samples=ABORT_SAMPLES))


def problems():
    """(energy-optimal, fuel-optimal) transfers with the constraints, on the J2 model."""
    o = orbit()
    T = REVOLUTIONS * float(o.period)
    cons = constraints(T)
    x0, xf = jnp.asarray(HOLD), jnp.asarray(ARRIVAL)
    energy = EnergyOptimalTransfer(o, x0, xf, T, model="j2", constraints=cons)
    fuel = FuelOptimalTransfer(o, x0, xf, T, thrust_max=THRUST_MAX, mass=MASS, isp=ISP,
                               model="j2", constraints=cons)
    return energy, fuel


def solve_fuel(problem, log):
    """The fuel family's `refine_transfer` stopped at its first mesh, FUEL_SEGMENTS uniform LGR
    segments of FUEL_POINTS points: the meshes after it (aligned with the switches, or split
    where the constraints fail between the nodes) did not converge on this case
    (docs/approach.md)."""
    t = time.perf_counter()
    sol = refine_fuel(problem, FUEL_OPTIONS, Judge(),
                      MeshLadder(((FUEL_SEGMENTS, FUEL_POINTS),)), passes=0)
    log(f"fuel-optimal with safety constraints: {Status(int(sol.status)).name}, delta-v "
        f"{float(sol.cost):.6f} m/s, error estimate {float(sol.stats['error_position']):.2e} "
        f"m, largest violation {float(jnp.max(sol.stats['constraint_violation'])):.2e}, "
        f"{int(sol.stats['mesh_passes'])} mesh passes ({time.perf_counter() - t:.1f} s)")
    return sol


def violations(sol):
    """Each safety constraint's largest continuous-time violation (SI; 0 where it holds)."""
    v = np.asarray(sol.stats["constraint_violation"], float)
    return {name: float(v[i]) for i, name in enumerate(CONSTRAINT_NAMES)}


def summary(sol, fuel_family):
    st = sol.stats
    t = np.linspace(0.0, float(sol.duration), 4001)
    out = {"status": Status(int(sol.status)).name,
           "delta_v_mps": float(sol.delta_v),
           "violations": violations(sol),
           "error_position_m": float(st["error_position"]),
           "error_velocity_mps": float(st["error_velocity"]),
           "mesh_points": int(np.asarray(sol.times).size),
           "min_range_to_target_m": float(np.min(np.linalg.norm(
               np.asarray(sol.states(t))[:, :3], axis=1)))}
    if fuel_family:
        out.update(fuel_g=1e3 * float(st["fuel"]),
                   thrust_excess_dv_mps=float(st["path_violation"]),
                   eps=float(st["eps"]),
                   burns_s=[[a, b] for a, b in burn_arcs(sol)],
                   status_by_eps=[Status(int(s)).name for s in np.asarray(st["status_by_eps"])],
                   dv_by_eps_mps=[float(v) for v in np.asarray(st["dv_by_eps"])])
    else:
        out.update(cost_m2ps3=float(sol.cost),
                   fuel_g=1e3 * float(sol.propellant(MASS, ISP)),
                   max_acceleration_mps2=float(np.max(np.linalg.norm(
                       np.asarray(sol.controls(t)), axis=1))))
    return out


def compute(log=print, beside=True):
    energy, fuel = problems()
    o = energy.orbit
    log(f"chief a = {A:.0f} m, e = {E}, i = {np.degrees(INCLINATION):.1f} deg, J2 = "
        f"{J2_EARTH}, period {float(o.period):.1f} s; transfer {float(energy.duration):.1f} s; "
        f"chaser {MASS} kg, {THRUST_MAX} N (u_max {THRUST_MAX / MASS:.1e} m/s^2), Isp {ISP} s")
    t0 = time.perf_counter()
    free_energy = solve(energy.replace(constraints=()), throw=False)
    log(f"energy-optimal without safety constraints: {Status(int(free_energy.status)).name}, "
        f"cost {float(free_energy.cost):.6e} m^2/s^3 ({time.perf_counter() - t0:.1f} s)")
    # beside=True: the constrained fuel-optimal solve runs in a thread beside the constrained
    # energy refinement (its programs are the dry run's; the refinement's later rungs compile
    # while it runs); a dry run (`reproduce`) is per thread, so it solves them in turn
    if beside:
        pool, fuel_lines = ThreadPoolExecutor(max_workers=1), []
        constrained_fuel = pool.submit(solve_fuel, fuel, fuel_lines.append)
    t = time.perf_counter()
    e_sol = refine_transfer(energy, ENERGY_OPTIONS, Judge(), ENERGY_LADDER)
    log(f"energy-optimal with safety constraints: {Status(int(e_sol.status)).name}, cost "
        f"{float(e_sol.cost):.6e} m^2/s^3, rung {int(e_sol.stats['rung']) + 1} of "
        f"{len(ENERGY_LADDER.rungs)} ({time.perf_counter() - t:.1f} s)")
    t = time.perf_counter()
    free_fuel = solve(fuel.replace(constraints=()), throw=False)
    log(f"fuel-optimal without safety constraints: {Status(int(free_fuel.status)).name}, "
        f"delta-v {float(free_fuel.cost):.6f} m/s ({time.perf_counter() - t:.1f} s)")
    if beside:
        f_sol = constrained_fuel.result()
        pool.shutdown()
        for line in fuel_lines:
            log(line)
    else:
        f_sol = solve_fuel(fuel, log)
    seconds = time.perf_counter() - t0
    computed = {
        "energy_optimal": summary(e_sol, False),
        "fuel_optimal": summary(f_sol, True),
        "without_safety": {
            "energy_optimal_cost_m2ps3": float(free_energy.cost),
            "energy_optimal_status": Status(int(free_energy.status)).name,
            "fuel_optimal_delta_v_mps": float(free_fuel.cost),
            "fuel_optimal_fuel_g": 1e3 * float(free_fuel.stats["fuel"]),
            "fuel_optimal_status": Status(int(free_fuel.status)).name},
        "tolerance": {"position_m": DEFAULT_TOLERANCE.position,
                      "velocity_mps": DEFAULT_TOLERANCE.velocity,
                      "thrust_excess_dv_mps": DEFAULT_TOLERANCE.path},
        "seconds": seconds,
        "case": {"chief": f"a = {A:.0f} m, e = {E}, i = 51.6 deg, f0 = 0 (perigee), mu = "
                          f"{MU_EARTH:.10e} m^3/s^2, J2 = {J2_EARTH}, R_eq = {R_EARTH} m",
                 "chaser": {"mass_kg": MASS, "thrust_max_N": THRUST_MAX, "isp_s": ISP},
                 "x0": list(HOLD), "xf": list(ARRIVAL), "port_m": list(PORT),
                 "duration_s": float(energy.duration),
                 "constraints": {
                     "keep_out": f"sphere {KEEP_OUT_RADIUS} m about the target, t <= "
                                 f"{KEEP_OUT_UNTIL} T",
                     "approach_cone": f"half-angle 10 deg about -V-bar from the port, within "
                                      f"{CONE_RANGE} m of it",
                     "speed_limit": f"|v| <= {SPEED_V0} m/s + {SPEED_K} /s x range to the port",
                     "passive_safety": f"free drift for one period (linear model, "
                                       f"{ABORT_SAMPLES} samples; checked at 4x) outside "
                                       f"{ABORT_RADIUS} m, from t <= {ABORT_UNTIL} T"},
                 "frame": "LVLH about the target: x radial outward, y along-track, z orbit "
                          "normal"},
    }
    return computed, (e_sol, f_sol)


NOTES = [
    "No paper: the numbers are ours. Every violation is the largest over a dense check "
    "between the nodes (the state polynomial and control interpolant at the check mesh; the "
    "abort drift at 4x the solver's samples), in m or m/s, 0 where the constraint holds.",
    f"Fuel-optimal: the continuation ends at eps = {FUEL_OPTIONS.eps[-1]:g} with |u| smoothed "
    f"by {FUEL_OPTIONS.smoothing:g} u_max (jaxlpm.solvers.fuel_constrained): its delta-v "
    f"exceeds the same mesh's fuel optimum by at most a fraction eps / (1 - eps). With the "
    f"family's default schedule the step at eps = 3e-3 converges on this case (24 outer "
    f"iterations), its delta-v 4.7e-5 relative below eps = 0.01's.",
    "A status INACCURATE means converged on the mesh with an error estimate or a violation "
    "between the nodes above the default tolerance (0.1 m, 1e-4 m/s, 1e-4 m/s of delta-v "
    "beyond the thrust bound); the numbers say by how much.",
]


def report(computed, log=print):
    c = computed
    log(f"\n{TITLE}\n")
    log(f"{'':<34}{'energy-optimal':>18}{'fuel-optimal':>18}")
    e, f = c["energy_optimal"], c["fuel_optimal"]
    log(f"{'status':<34}{e['status']:>18}{f['status']:>18}")
    log(f"{'delta-v (m/s)':<34}{e['delta_v_mps']:>18.6f}{f['delta_v_mps']:>18.6f}")
    log(f"{'fuel (g)':<34}{e['fuel_g']:>18.4f}{f['fuel_g']:>18.4f}")
    for name in CONSTRAINT_NAMES:
        log(f"{'violation ' + name:<34}{e['violations'][name]:>18.2e}"
            f"{f['violations'][name]:>18.2e}")
    log(f"{'error estimate (m)':<34}{e['error_position_m']:>18.2e}{f['error_position_m']:>18.2e}")
    log(f"{'collocation points':<34}{e['mesh_points']:>18d}{f['mesh_points']:>18d}")
    w = c["without_safety"]
    log(f"\nwithout the safety constraints: energy cost {w['energy_optimal_cost_m2ps3']:.4e} "
        f"m^2/s^3 (with: {e['cost_m2ps3']:.4e}); fuel-optimal delta-v "
        f"{w['fuel_optimal_delta_v_mps']:.6f} m/s (with: {f['delta_v_mps']:.6f})")
    log("fuel-optimal burns (s): "
        + ", ".join(f"[{a:.0f}, {b:.0f}]" for a, b in f["burns_s"]))
    log("")
    for note in NOTES:
        log(f"- {note}")


def figures(computed, data, out_dir):
    """The trajectories in the orbit plane with the zones, speed against range with the
    limit, and the thrust magnitudes against time."""
    from .plots import _save, plt

    paths = []
    labels = ("energy-optimal", "fuel-optimal")
    samples = [np.linspace(0.0, float(s.duration), 3001) for s in data]
    states = [np.asarray(s.states(t)) for s, t in zip(data, samples)]
    fig, ax = plt.subplots(figsize=(9, 5))
    for x, label in zip(states, labels):
        ax.plot(x[:, 1], x[:, 0], label=label)
    theta = np.linspace(0.0, 2.0 * np.pi, 400)
    for r, style, name in ((KEEP_OUT_RADIUS, "r--", "keep-out sphere"),
                           (ABORT_RADIUS, "m:", "abort-safety sphere")):
        ax.plot(r * np.cos(theta), r * np.sin(theta), style, lw=1, label=name)
    for sign in (-1.0, 1.0):
        ax.plot([PORT[1], PORT[1] - CONE_RANGE * np.cos(CONE_HALF_ANGLE)],
                [PORT[0], sign * CONE_RANGE * np.sin(CONE_HALF_ANGLE)], "g-", lw=1,
                label="approach cone" if sign > 0 else None)
    ax.plot([PORT[1]], [PORT[0]], "ks", ms=4, label="docking port")
    ax.set(xlabel="y along-track (m)", ylabel="x radial (m)", aspect="equal",
           title="V-bar approach under J2 (LVLH about the target)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    paths.append(_save(fig, out_dir / "trajectory.png"))

    fig, ax = plt.subplots(figsize=(7, 4))
    for x, label in zip(states, labels):
        rng = np.linalg.norm(x[:, :3] - np.asarray(PORT), axis=1)
        ax.plot(rng, np.linalg.norm(x[:, 3:], axis=1), label=label)
    rng = np.linspace(0.0, 1000.0, 200)
    ax.plot(rng, SPEED_V0 + SPEED_K * rng, "r--", label="speed limit")
    ax.set(xlabel="range to the port (m)", ylabel="|v| (m/s)", xscale="symlog",
           title="speed against range")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    paths.append(_save(fig, out_dir / "speed_range.png"))

    fig, ax = plt.subplots(figsize=(8, 4))
    for s, t, label in zip(data, samples, labels):
        ax.plot(t, np.linalg.norm(np.asarray(s.controls(t)), axis=1), label=label)
    ax.axhline(THRUST_MAX / MASS, color="r", ls="--", lw=1, label="u_max")
    ax.set(xlabel="t (s)", ylabel="|u| (m/s^2)", title="thrust acceleration")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    paths.append(_save(fig, out_dir / "thrust.png"))
    return paths


def reproduce(out_dir, log=print):
    """Run the case: compute (its first programs traced by a dry run,
    `jaxlpm.compilation.prefetch`, and compiled two at a time while it runs: the dry run's
    zeros read as SUCCESS, so each refinement stops at its first mesh there and the later
    rungs compile when the real run reaches them), print, draw. Returns the JSON-ready
    result dict."""
    prefetch_case(lambda: compute(log=lambda msg: None, beside=False), log,
                  what="first programs")
    computed, data = compute(log)
    return finish(sys.modules[__name__], computed,
                  lambda out: figures(computed, data, out), out_dir, log)
