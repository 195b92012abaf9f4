"""The condensed transcription on LGL segments (issue 19), measured to decide whether the fuel
homotopy and minimum-time method "condensed" should take them.

An LGL segment collocates both its ends: its n defects D X = h (A X + B U + c) over-determine
its n - 1 state rows after its start, so the segment leaves n_x conditions on its controls
(`jaxlpm.problems.fuel_optimal._segment_maps`), which join the final state as rows of the
condensed affine map (m = 6 (K + 1) multipliers in the dual). Printed:

1. the conditions that a coast (U = 0) leaves unmet on each of K uniform LGL segments of an HCW
   orbit: nonzero, so no LGL segment can coast exactly;
2. the 4 km fuel-optimal transfer of the tests by the homotopy on LGL and LG segments
   (status, delta-v, estimate, time);
3. minimum time (Tschauner-Hempel, e = 0.2) by method "condensed" on LGL and LG segments
   against the shooting solution.

    python experiments/lgl_condensed.py
"""

import time

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

import jaxlpm as lpm  # noqa: E402
from jaxlpm.constants import R_EARTH  # noqa: E402
from jaxlpm.problems.fuel_optimal import condensed_mesh  # noqa: E402

CIRCULAR = lpm.KeplerOrbit(a=jnp.asarray(R_EARTH + 400e3), e=jnp.asarray(0.0))
ECCENTRIC = lpm.KeplerOrbit(a=jnp.asarray(9000e3), e=jnp.asarray(0.2))


def coast_conditions():
    """HCW in s = n t: the conditions Phi x0 + o (U = 0) beyond the final state's rows."""
    A = jnp.zeros((6, 6)).at[:3, 3:].set(jnp.eye(3))
    A = A.at[3, 0].set(3.0).at[3, 4].set(2.0).at[4, 3].set(-2.0).at[5, 2].set(-1.0)
    B = jnp.zeros((6, 3)).at[3:].set(jnp.eye(3))
    x0 = jnp.array([0.1, 0.4, 0.05, 0.0, -0.2, 0.01])
    for k, n in ((4, 8), (24, 8), (24, 16)):
        mesh = lpm.segmented_lgl(lpm.uniform_breaks(0.0, 2.0 * np.pi, k), n)
        cond = condensed_mesh(A, B, mesh)
        unmet = np.abs(np.asarray(cond.Phi @ x0 + cond.o)[6:]).max()
        print(f"  {k} x {n} LGL points over one orbit: largest unmet condition of a coast "
              f"{unmet:.1e} (state of size {float(jnp.max(jnp.abs(x0))):.1f})")


def main():
    print("1. a coast on LGL segments (HCW, U = 0):")
    coast_conditions()
    fuel = lpm.FuelOptimalTransfer(CIRCULAR, jnp.zeros(6), jnp.array([0.0, 4000.0, 0, 0, 0, 0]),
                                   jnp.asarray(float(CIRCULAR.period)), jnp.asarray(0.3),
                                   jnp.asarray(50.0), jnp.asarray(1000.0))
    print("2. fuel-optimal, HCW, 4 km along-track in one period, the homotopy (m/s):")
    for k in (4, 24):
        for scheme in ("LGL", "LG"):
            t = time.perf_counter()
            mesh = lpm.segmented_mesh(lpm.uniform_breaks(0.0, 1.0, k), 8, scheme)
            sol = lpm.solve(fuel, mesh, throw=False)
            print(f"  {k} x 8 {scheme}: {lpm.Status(int(sol.status)).name}, "
                  f"{float(sol.cost):.7f}, eps reached {float(sol.stats['eps']):.1e}, estimate "
                  f"{float(sol.stats['error_position']):.1e} m, "
                  f"{time.perf_counter() - t:.1f} s", flush=True)
    mt = lpm.MinimumTimeTransfer(ECCENTRIC, jnp.zeros(6), jnp.array([0.0, 1000.0, 0, 0, 0, 0]),
                                 thrust=jnp.asarray(0.1), mass=jnp.asarray(100.0))
    shot = float(lpm.min_time_shooting(mt, np.linspace(0.0, 1.0, 17), 16).duration)
    print(f"3. minimum time, e = 0.2, 1 km along-track, method 'condensed' (shooting "
          f"{shot:.7f} s):")
    for k in (8, 16):
        for scheme in ("LGL", "LG"):
            t = time.perf_counter()
            mesh = lpm.segmented_mesh(lpm.uniform_breaks(0.0, 1.0, k), 8, scheme)
            sol = lpm.solve(mt, mesh, throw=False)
            print(f"  {k} x 8 {scheme}: {lpm.Status(int(sol.status)).name}, "
                  f"{(float(sol.duration) - shot) / shot:+.1e} relative, estimate "
                  f"{float(sol.stats['error_position']):.1e} m, "
                  f"{time.perf_counter() - t:.1f} s", flush=True)


if __name__ == "__main__":
    main()
