"""Fuel-optimal transfers on an eccentric chief (issue 22): convergence with the mesh on the
linear (Tschauner-Hempel), two-body and J2 models.

The chief: a = 10000 km, e = 0.3 (perigee 7000 km), equatorial; the transfer from rest at
the chief to 8 km along-track, at rest, in one chief period (10 km scale), 0.3 N on 50 kg
(u_max = 6 mm/s^2), Isp 1000 s. For each model: uniform meshes of K = 12, 24, 48, 96 LGR
segments of 8 points, then the default solve (`jaxlpm.solve(problem)`: switch-aligned
refinement to the default tolerance), each flown by `jaxlpm.verify.fly` on its own model.
Prints a Markdown table (fuel in g, delta-v in m/s, status, the error estimate, the thrust
bound's overshoot between the nodes, the flown terminal miss, the wall time of the solve
with compilation) and writes it to experiments/results/fuel_eccentric_convergence.md as it
goes.

    python experiments/fuel_eccentric_convergence.py
"""

import pathlib
import time

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

import jaxlpm as lpm  # noqa: E402

OUT = pathlib.Path(__file__).parent / "results" / "fuel_eccentric_convergence.md"
MODELS = ("linear", "two-body", "j2")
SEGMENTS = (12, 24, 48, 96)


def problem(model):
    orbit = lpm.KeplerOrbit(a=10000e3, e=0.3)
    return lpm.FuelOptimalTransfer(orbit, jnp.zeros(6), jnp.array([0.0, 8e3, 0, 0, 0, 0]),
                                   orbit.period, 0.3, 50.0, 1000.0, model=model)


def row(model, mesh_name, sol, seconds):
    st = sol.stats
    miss = np.asarray(lpm.verify.fly(sol).terminal_error)
    return (f"| {model} | {mesh_name} | {1e3 * float(st['fuel']):.9f} | {float(sol.cost):.9f} "
            f"| {lpm.Status(int(sol.status)).name} | {float(st['error_position']):.1e} "
            f"| {float(st['path_violation']):.1e} | {miss[0]:.1e} | {miss[1]:.1e} "
            f"| {seconds:.1f} |")


def main():
    OUT.parent.mkdir(exist_ok=True)
    lines = ["| model | mesh | fuel (g) | delta-v (m/s) | status | est. (m) | overshoot (m/s) "
             "| flown miss (m) | (m/s) | solve (s) |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    print("\n".join(lines))
    for model in MODELS:
        p = problem(model)
        for k in SEGMENTS:
            mesh = lpm.segmented_lgr(lpm.uniform_breaks(0.0, 1.0, k), 8)
            t = time.perf_counter()
            sol = lpm.solve(p, mesh, throw=False)
            lines.append(row(model, f"{k} x 8 uniform", sol, time.perf_counter() - t))
            print(lines[-1], flush=True)
            OUT.write_text("\n".join(lines) + "\n")
        t = time.perf_counter()
        sol = lpm.solve(p, throw=False)
        name = (f"default: {sol.grid.n_segments} x 8 aligned, "
                f"{int(sol.stats['mesh_passes'])} passes")
        lines.append(row(model, name, sol, time.perf_counter() - t))
        print(lines[-1], flush=True)
        OUT.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
