"""Minimum-time transfers on an eccentric chief (issue 22, item 3): method "condensed" on the
linear (Tschauner-Hempel), two-body and J2 models against the shooting solution on the exact
Yamanaka-Ankersen flow, and at e = 0 against the HCW augmented-Lagrangian solver; the
augmented Lagrangian on the chief's true anomaly (issue 19) on the same LGR mesh and on an LGL
ladder.

The transfer: 0.05 N on 200 kg (0.25 mm/s^2) from rest at the chief to (500, 3000, -100) m
at rest (tests/test_min_time_eccentric.py), the chief at a = 10000 km, e = 0.3 (at e = 0:
a = R_E + 400 km). Each row: t_f, its difference from the shooting t_f (linear model), the
status, the error estimate, the linearisations, the flown terminal miss, the wall time with
compilation. Prints a Markdown table and writes it to experiments/results/min_time_eccentric.md
as it goes.

    python experiments/min_time_eccentric.py
    python experiments/min_time_eccentric.py --gradient   # the augmented Lagrangian's dt_f/dT

--gradient: dt_f/dT (s/N) of the two-body transfer by the augmented Lagrangian on 16 x 8 LGR
points, by `jax.grad` (the implicit function theorem at the KKT point) against central
differences of t_f (step 1e-6 N).
"""

import argparse
import pathlib
import time

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

import jaxlpm as lpm  # noqa: E402

OUT = pathlib.Path(__file__).parent / "results" / "min_time_eccentric.md"
XF = jnp.array([500.0, 3000.0, -100.0, 0.0, 0.0, 0.0])
PANELS = np.linspace(0.0, 1.0, 201)


def problem(e, model):
    orbit = lpm.KeplerOrbit(a=10000e3 if e > 0 else 6778137.0, e=e)
    return lpm.MinimumTimeTransfer(orbit, jnp.zeros(6), XF, 0.05, 200.0, model=model)


def main():
    OUT.parent.mkdir(exist_ok=True)
    lines = ["| e | model | method, mesh | t_f (s) | vs shooting | status | est. (m) "
             "| linearisations | flown miss (m) | (m/s) | solve (s) |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    print("\n".join(lines))
    shooting = {e: float(lpm.min_time_shooting(problem(e, "linear"), PANELS).duration)
                for e in (0.0, 0.3)}
    al = "augmented-lagrangian"
    lgr16 = lpm.segmented_lgr(lpm.uniform_breaks(0.0, 1.0, 16), 8)
    lgl_ladder = lpm.MeshLadder(((1, 32), (2, 48)), scheme="LGL")
    cases = [(0.0, "linear", al, None),
             (0.0, "linear", "condensed", lgr16), (0.3, "linear", "condensed", lgr16),
             (0.3, "two-body", "condensed", lgr16), (0.3, "j2", "condensed", lgr16),
             (0.3, "linear", al, lgr16), (0.3, "two-body", al, lgr16),
             (0.3, "linear", al, lgl_ladder), (0.3, "two-body", al, lgl_ladder)]
    for e, model, method, grid in cases:
        p = problem(e, model)
        t = time.perf_counter()
        sol = lpm.solve(p, grid, method=method, throw=False)
        shape = f"{sol.grid.n_segments} x {sol.grid.segment.n} {sol.grid.segment.scheme}"
        mesh = f"default: {shape}" if grid is None else shape
        if isinstance(grid, lpm.MeshLadder):
            mesh = f"LGL ladder (1 x 32, 2 x 48): {shape}"
        seconds = time.perf_counter() - t
        T = float(sol.duration)
        miss = np.asarray(lpm.verify.fly(sol).terminal_error)
        lines.append(
            f"| {e} | {model} | {method}, {mesh} | {T:.6f} | {(T - shooting[e]) / shooting[e]:.1e} "
            f"| {lpm.Status(int(sol.status)).name} | {float(sol.stats['error_position']):.1e} "
            f"| {int(sol.stats.get('linearisations', 0))} | {miss[0]:.1e} | {miss[1]:.1e} "
            f"| {seconds:.1f} |")
        print(lines[-1], flush=True)
        OUT.write_text("\n".join(lines) + "\n")


def gradient():
    mesh = lpm.segmented_lgr(lpm.uniform_breaks(0.0, 1.0, 16), 8)

    def t_f(thrust):
        return lpm.solve(problem(0.3, "two-body").replace(thrust=thrust), mesh,
                         method="augmented-lagrangian", throw=False).duration

    g = float(jax.grad(t_f)(jnp.asarray(0.05)))
    h = 1e-6
    fd = (float(t_f(jnp.asarray(0.05 + h))) - float(t_f(jnp.asarray(0.05 - h)))) / (2 * h)
    print(f"two-body, augmented Lagrangian, 16 x 8 LGR: dt_f/dT = {g:.10e} s/N (jax.grad), "
          f"{fd:.10e} (central differences), relative difference {abs(g - fd) / abs(fd):.1e}")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--gradient", action="store_true", help="the gradient check alone")
    if parser.parse_args().gradient:
        gradient()
    else:
        main()
