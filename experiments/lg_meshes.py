"""LG and LGL meshes in the fuel-optimal and minimum-time families against LGR (issue 19):
the refined solutions' status, cost, passes, error estimate and flown plan error, and the
minimum times against the shooting solution (`min_time_shooting`, exact flow). The fuel
ladders of LGL segments are solved by the augmented Lagrangian (the homotopy's condensed
transcription takes LGR and LG segments).

    python experiments/lg_meshes.py              # every family
    python experiments/lg_meshes.py --min-time   # the minimum-time cases alone

Results: docs/accuracy.md ("LG and LGL meshes in every family").
"""

import argparse
import time

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

import jaxlpm as lpm  # noqa: E402
from jaxlpm.constants import R_EARTH  # noqa: E402

CIRCULAR = lpm.KeplerOrbit(a=jnp.asarray(R_EARTH + 400e3), e=jnp.asarray(0.0))
ECCENTRIC = lpm.KeplerOrbit(a=jnp.asarray(9000e3), e=jnp.asarray(0.2))
SHOOTING = (np.linspace(0.0, 1.0, 17), 16)       # 16 panels of 16 Gauss nodes


def row(label, sol, value, seconds, reference=None):
    flight = lpm.verify.fly(sol)
    extra = "" if reference is None else f", {(value - reference) / reference:+.1e} relative"
    passes = sol.stats.get("mesh_passes", sol.stats.get("rung", 0) + 1)
    print(f"{label}: {lpm.Status(int(sol.status)).name}, {value:.10f}{extra}, "
          f"{type(sol.grid).__name__} {sol.grid.n_segments} x {sol.grid.segment.n}, "
          f"passes {int(passes)}, estimate {float(sol.stats['error_position']):.1e} m, "
          f"flown plan error {float(flight.plan_error[0]):.1e} m, path violation "
          f"{float(sol.stats.get('path_violation', 0.0)):.1e}, {seconds:.1f} s", flush=True)


def timed(fn):
    t = time.perf_counter()
    out = fn()
    return out, time.perf_counter() - t


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--min-time", action="store_true", help="the minimum-time cases alone")
    if not parser.parse_args().min_time:
        fuel_cases()
    min_time_cases()


def fuel_cases():
    fuel = lpm.FuelOptimalTransfer(CIRCULAR, jnp.zeros(6), jnp.array([0.0, 4000.0, 0, 0, 0, 0]),
                                   jnp.asarray(float(CIRCULAR.period)), jnp.asarray(0.3),
                                   jnp.asarray(50.0), jnp.asarray(1000.0))
    print("fuel-optimal, HCW, 4 km along-track in one period (m/s of delta-v):")
    for scheme in ("LGR", "LG", "LGL"):
        sol, s = timed(lambda: lpm.solve(fuel, lpm.MeshLadder(((4, 8), (24, 8)), scheme),
                                         throw=False))
        row(f"  {scheme} ladder 4 x 8, 24 x 8", sol, float(sol.cost), s)
    mesh = lpm.segmented_lgr(lpm.uniform_breaks(0.0, 1.0, 24), 8)
    for method in ("homotopy", "augmented-lagrangian"):
        sol, s = timed(lambda: lpm.solve(fuel, mesh, method=method, throw=False))
        row(f"  {method} on 24 x 8 LGR points", sol, float(sol.cost), s)
    eccentric = fuel.replace(orbit=ECCENTRIC, duration=jnp.asarray(float(ECCENTRIC.period)),
                             model="two-body")
    print("fuel-optimal, two-body, e = 0.2, one period:")
    for scheme in ("LGR", "LG", "LGL"):
        sol, s = timed(lambda: lpm.solve(eccentric, lpm.MeshLadder(((24, 8), (48, 8)), scheme),
                                         throw=False))
        row(f"  {scheme} ladder 24 x 8, 48 x 8", sol, float(sol.cost), s)


def min_time_cases():
    mt = lpm.MinimumTimeTransfer(ECCENTRIC, jnp.zeros(6), jnp.array([0.0, 1000.0, 0, 0, 0, 0]),
                                 thrust=jnp.asarray(0.1), mass=jnp.asarray(100.0))
    shot = float(lpm.min_time_shooting(mt, *SHOOTING).duration)
    print(f"minimum time, Tschauner-Hempel e = 0.2, 1 km along-track, 0.1 N on 100 kg "
          f"(s; shooting {shot:.10f}):")
    for scheme in ("LGR", "LG"):
        sol, s = timed(lambda: lpm.solve(mt, lpm.MeshLadder(((8, 8), (16, 8)), scheme),
                                         throw=False))
        row(f"  condensed, {scheme} ladder 8 x 8, 16 x 8", sol, float(sol.duration), s, shot)
    sol, s = timed(lambda: lpm.solve(mt, lpm.MeshLadder(((8, 8), (16, 8)), "LGL"),
                                     throw=False))
    row("  augmented Lagrangian (true anomaly), LGL ladder 8 x 8, 16 x 8", sol,
        float(sol.duration), s, shot)
    for mesh in (lpm.lgl_mesh(4, 8), lpm.lgl_mesh(8, 8), lpm.lgl_mesh(16, 8),
                 lpm.lgl_mesh(32, 8)):
        sol, s = timed(lambda: lpm.solve(mt, mesh, throw=False))
        row("  augmented Lagrangian (true anomaly)", sol, float(sol.duration), s, shot)
    two_body = mt.replace(model="two-body")
    print("minimum time, two-body, the same transfer (s; relative to the condensed 16 x 8 LG):")
    reference = float(lpm.solve(two_body, lpm.segmented_lg(lpm.uniform_breaks(0.0, 1.0, 16), 8),
                                throw=False).duration)
    for mesh in (lpm.lgl_mesh(8, 8), lpm.lgl_mesh(16, 8)):
        sol, s = timed(lambda: lpm.solve(two_body, mesh, throw=False))
        row("  augmented Lagrangian (true anomaly)", sol, float(sol.duration), s, reference)

    hcw = mt.replace(orbit=CIRCULAR)
    shot = float(lpm.min_time_shooting(hcw, *SHOOTING).duration)
    print(f"minimum time, HCW, the same transfer (s; shooting {shot:.10f}):")
    for mesh in (lpm.lg_mesh(4, 8), lpm.lg_mesh(8, 8), lpm.lgl_mesh(4, 8), lpm.lgl_mesh(8, 8),
                 lpm.lgl_mesh(16, 8), lpm.lgr_mesh(8, 8)):
        sol, s = timed(lambda: lpm.solve(hcw, mesh, throw=False))
        row("  augmented Lagrangian", sol, float(sol.duration), s, shot)


if __name__ == "__main__":
    main()
