"""How the flown miss and drift rate of the duan case depend on how the nodal thrust
directions are interpolated (the paper used cubic splines; `jaxlpm reproduce duan` uses
barycentric Lagrange over the LG points), against the exact optimum from shooting.

    python experiments/duan_interpolation.py [--K 100]      (needs the `test` extra: scipy)

Each nodal direction history (LG, K points, plus the ends taken from the collocated
solution's neighbours) is interpolated, renormalised to |u| = 1 and flown through the CW
equations with scipy's DOP853 (rtol 1e-12); prints the terminal miss and the paper's drift
rate 3 v_xD + 6 n y_D.
"""

import argparse

import numpy as np
from scipy.integrate import solve_ivp
from scipy.interpolate import CubicSpline, interp1d

from jaxlpm.cli import _setup_jax

_setup_jax()

import jax  # noqa: E402

from jaxlpm import make_grid, solve  # noqa: E402
from jaxlpm.cases import duan  # noqa: E402
from jaxlpm.dynamics import hcw_matrix  # noqa: E402


def fly(control, prob, tf):
    A = np.asarray(hcw_matrix(float(prob.orbit.mean_motion)))
    a = float(prob.acceleration)

    def rhs(t, x):
        u = control(t)
        return A @ x + np.concatenate([np.zeros(3), a * u / np.linalg.norm(u)])

    sol = solve_ivp(rhs, (0.0, tf), np.asarray(prob.x0), method="DOP853", rtol=1e-12,
                    atol=1e-12, max_step=tf / 2000)
    return sol.y[:, -1]


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--K", type=int, default=100)
    args = parser.parse_args()
    prob = duan.problem()
    sol = solve(prob, make_grid("LG", args.K))
    tf = float(sol.duration)
    t = np.asarray(sol.times)
    U = np.asarray(sol.stats["node_directions"])
    controls_at = jax.jit(sol.controls)       # barycentric, renormalised to T / m (m/s^2)
    bary = lambda s: np.asarray(controls_at(s))  # noqa: E731
    controls = {
        "barycentric (reproduce)": bary,
        "cubic spline (paper)": CubicSpline(t, U, axis=0),
        "piecewise linear": interp1d(t, U, axis=0, fill_value="extrapolate"),
    }
    xf = np.asarray(prob.xf)
    n = float(prob.orbit.mean_motion)
    print(f"LG K = {args.K}: t_f = {tf:.6f} s")
    print(f"{'interpolation':<26}{'miss (m)':>12}{'miss (m/s)':>12}{'drift (m/s)':>14}")
    for name, control in controls.items():
        x = fly(control, prob, tf)
        print(f"{name:<26}{np.linalg.norm(x[:3] - xf[:3]):>12.3e}"
              f"{np.linalg.norm(x[3:] - xf[3:]):>12.3e}{float(duan.drift_rate(x, n)):>14.3e}")


if __name__ == "__main__":
    main()
