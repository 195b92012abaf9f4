"""Costate estimates of LGL, LG and LGR against the analytic costate (issue 3 acceptance).

Problem: the minimum-energy HCW transfer in nondimensional units (time 1/n, unit length),
x' = A x + [0; u], cost 1/2 int |u|^2 dt, x(0) = [1, 1, 0.5, 0, -0.5, 0.1], x(3) = 0. By the
maximum principle u = -B^T lam and lam(t) = exp(-A^T t) lam0, lam0 = G^-1 Phi(T) x0 with the
Gramian G = int_0^T Phi(T - s) B B^T exp(-A^T s) ds (scipy quad_vec + expm: independent of
jaxlpm). The Newton-KKT solver's costate estimates (`jaxlpm.nlp.transcription.costates`)
are compared at every collocation point, per scheme and number of points.

    python experiments/costate_convergence.py [--points 8 12 16 24]
"""

import argparse

import jax
import jax.numpy as jnp
import numpy as np
import scipy.integrate
import scipy.linalg

jax.config.update("jax_enable_x64", True)

import jaxlpm as lpm  # noqa: E402
from jaxlpm.dynamics import hcw_matrix  # noqa: E402
from jaxlpm.nlp import OptimalControlProblem  # noqa: E402
from jaxlpm.nlp import transcription as tr  # noqa: E402

X0 = np.array([1.0, 1.0, 0.5, 0.0, -0.5, 0.1])
T = 3.0


def dynamics(s, x, u, data, p):
    return hcw_matrix(1.0) @ x + jnp.concatenate([jnp.zeros(3), u])


def energy(s, x, u, data, p):
    return 0.5 * jnp.dot(u, u)


def fixed_ends(x0, xf, sf, p):
    return jnp.concatenate([x0 - p["x0"], xf - p["xf"]])


def analytic_costate(t):
    A = np.asarray(hcw_matrix(1.0))
    B = np.vstack([np.zeros((3, 3)), np.eye(3)])
    G = scipy.integrate.quad_vec(
        lambda s: scipy.linalg.expm(A * (T - s)) @ B @ B.T @ scipy.linalg.expm(-A.T * s),
        0.0, T, epsabs=1e-14, epsrel=1e-14)[0]
    lam0 = np.linalg.solve(G, scipy.linalg.expm(A * T) @ X0)
    return np.stack([scipy.linalg.expm(-A.T * ti) @ lam0 for ti in t])


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, nargs="+", default=[8, 12, 16, 24])
    args = parser.parse_args(argv)
    ocp = OptimalControlProblem(n_x=6, n_u=3, dynamics=dynamics, running_cost=energy,
                                boundary=fixed_ends, s0=jnp.array(0.0), sf=jnp.array(T),
                                params={"x0": jnp.asarray(X0), "xf": jnp.zeros(6)})
    print(f"{'scheme':<7}{'points':>7}{'status':>8}{'max rel err':>14}"
          f"{'first node':>12}{'interior max':>14}{'last node':>12}")
    for scheme in ("LGL", "LG", "LGR"):
        for n in args.points:
            grid = lpm.make_grid(scheme, n)
            res = lpm.nlp.newton_kkt(ocp, grid, jnp.zeros(tr.n_variables(ocp, grid)))
            lam = np.asarray(tr.costates(res.z, res.multipliers, ocp, grid))
            exact = analytic_costate(np.asarray(tr.collocation_s(ocp, grid)))
            err = np.max(np.abs(lam - exact), axis=1) / np.max(np.abs(exact))
            print(f"{scheme:<7}{n:>7}{lpm.Status(int(res.status)).name:>8}{err.max():>14.2e}"
                  f"{err[0]:>12.2e}{err[1:-1].max():>14.2e}{err[-1]:>12.2e}")


if __name__ == "__main__":
    main()
