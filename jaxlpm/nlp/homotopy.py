"""Energy-to-fuel homotopy for bounded-thrust transfers on linear dynamics (Yue & Duan 2016,
§2.2; Bertrand & Epenoy 2002; the continuation of Haberkorn, Martinon & Gergaud 2004).

The transcribed problem (`jaxlpm.problems.fuel_optimal`) after eliminating the states is

    min_v  sum_i c_i l_eps(|v_i|)   s.t.  r(v) = sum_i E_i v_i - d = 0,   |v_i| <= 1,

v_i = u_i / u_max at the collocation points, c_i = u_max x (quadrature weight), E_i (n_x, 3)
the control's effect on the final state, l_eps(w) = w - eps w (1 - w). It is convex, and
separable in the v_i; |v| is not differentiable at v = 0, where the coast arcs sit, so Newton on
the primal variables would face a singular Hessian there. Its Lagrangian dual is smooth for
eps > 0 and has only n_x unknowns, the multipliers nu of the final state:

    v_i(nu) = argmin_|v|<=1 l_eps(|v|) - p_i . v = throttle(|p_i|) p_i / |p_i|,
    p_i = -E_i^T nu / c_i       (the primer vector: -lambda_v of the collocation costates)
    g(nu) = sum_i c_i [l_eps(|v_i|) - p_i . v_i] - nu . d,    grad g = r(v(nu)),

maximised (g concave) by Newton's method on r(nu) = 0 with an Armijo line search on g; with
strong duality (the transcribed problem is feasible with |v| < 1 somewhere) its v(nu) solves
the transcribed problem, and r(nu) = 0 is the discrete form of shooting on the costates.

The homotopy: eps = 1 from nu = 0 or a given guess (a QP when the bound is inactive: one
Newton step), then eps <- eps 10^(-step), warm-started, inside one `lax.while_loop`. A
converged step doubles the step (up to max_step); a failed one restores nu and halves it.
Status: SUCCESS when eps reached eps_min; STALLED when the step fell below min_step first (eps
could not be driven small: the result is the last converged eps); INFEASIBLE when the first
solve (eps = 1) failed with every point at full thrust or with the dual ascent running away
(the bound cannot reach the target in the time: the feasible set is the same at every eps, so
a later failure is a smaller step, never INFEASIBLE); MAX_ITERATIONS, NONFINITE otherwise.
"""

from dataclasses import dataclass
from typing import NamedTuple

import jax
import jax.numpy as jnp

from ..compilation import compiled
from ..linalg import small_spd_solve
from ..status import Status

_RUNNING = -1


def smoothed_cost(w, eps):
    """Integrand per u_max of the smoothed cost: w - eps w (1 - w) (paper eq. 31)."""
    return w - eps * w * (1.0 - w)


def throttle(S, eps):
    """The minimiser w in [0, 1] of smoothed_cost(w) - S w: clip((S - 1 + eps) / (2 eps), 0, 1)
    (paper eq. 33 with rho = 1 - S)."""
    return jnp.clip((S - 1.0 + eps) / (2.0 * eps), 0.0, 1.0)


def pointwise_control(p, eps):
    """u / u_max = throttle(|p|) p / |p| for a primer vector p (3,); smooth at p = 0 for
    eps >= 1 (where it is p / 2 for |p| < 2) and zero there otherwise."""
    S2 = jnp.dot(p, p)
    safe = S2 > 0.0
    S = jnp.sqrt(jnp.where(safe, S2, 1.0))
    ratio = jnp.where(safe, throttle(S, eps) / S, jnp.where(eps >= 1.0, 0.5 / eps, 0.0))
    return ratio * p


@dataclass(frozen=True)
class HomotopyOptions:
    """Static settings (hashable: one compiled solver per distinct set).

    eps_min        the smoothing the homotopy drives eps down to
    first_step, max_step, min_step   decrease of log10(eps) per step: first, largest, and the
                   smallest before giving up (STALLED)
    max_steps      homotopy steps (converged or not) at most
    max_newton     Newton iterations per eps
    max_backtracks step lengths 2^-j tried by the line search (j < max_backtracks)
    tol            max |r| at convergence (solver units: lengths in L, velocities in L n)
    max_linearisations  homotopies on successive linearisations of nonlinear dynamics at most
                   (`jaxlpm.solvers.fuel_optimal`)
    linearisation_tol   they stop when the collocated states move by at most this (solver
                   units)
    """

    eps_min: float = 1e-6
    first_step: float = 0.25
    max_step: float = 1.0
    min_step: float = 1e-3
    max_steps: int = 100
    max_newton: int = 30
    tol: float = 1e-11
    max_backtracks: int = 16
    armijo: float = 1e-4
    max_linearisations: int = 12
    linearisation_tol: float = 1e-8


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class HomotopyResult:
    """Outcome of `energy_to_fuel`.

    nu, eps              final-state multipliers at the last converged eps, and that eps
    nu_energy            the multipliers at eps = 1 (the energy-like solution)
    status               `Status` (int32; see the module docstring)
    steps, failed_steps  homotopy steps taken and how many of them failed (then halved)
    newton_iterations    in all
    residual             max |r| at nu (solver units); energy_residual: at nu_energy
    """

    nu: jax.Array
    eps: jax.Array
    nu_energy: jax.Array
    status: jax.Array
    steps: jax.Array
    failed_steps: jax.Array
    newton_iterations: jax.Array
    residual: jax.Array
    energy_residual: jax.Array


def primers(nu, E, c):
    """p_i = -E_i^T nu / c_i, (m, 3)."""
    return -jnp.einsum("iab,a->ib", E, nu) / c[:, None]


def controls(nu, E, c, eps):
    """v_i(nu) = u_i / u_max, (m, 3)."""
    return jax.vmap(pointwise_control, in_axes=(0, None))(primers(nu, E, c), eps)


def residual(nu, E, c, d, eps):
    """r(nu) = sum_i E_i v_i(nu) - d."""
    return jnp.einsum("iab,ib->a", E, controls(nu, E, c, eps)) - d


def dual(nu, E, c, d, eps):
    """g(nu) = sum_i c_i [l_eps(|v_i|) - p_i . v_i] - nu . d (concave; maximised)."""
    p, v = primers(nu, E, c), controls(nu, E, c, eps)
    w = jnp.linalg.norm(v, axis=1)
    return jnp.sum(c * (smoothed_cost(w, eps) - jnp.sum(p * v, axis=1))) - nu @ d


def _diverged(nu, E, c):
    """The dual ascent runs away (|p| 1e8 times the switching threshold, where a solution has
    |p| = O(1)): g is unbounded above, i.e. the transcribed problem is infeasible (the bound
    cannot reach the target)."""
    return jnp.max(jnp.linalg.norm(primers(nu, E, c), axis=1)) > 1e8


class _DualNewtonState(NamedTuple):
    nu: jax.Array
    k: jax.Array
    residual: jax.Array          # max |r(nu)|
    done: jax.Array
    failed: jax.Array


class _HomotopyState(NamedTuple):
    nu: jax.Array
    eps: jax.Array
    step: jax.Array              # decrease of log10(eps) of the next step
    steps: jax.Array
    failed_steps: jax.Array
    newton_iterations: jax.Array
    residual: jax.Array
    status: jax.Array            # _RUNNING until done


def newton_dual(nu0, E, c, d, eps, options: HomotopyOptions):
    """Newton's method on r(nu) = 0 from nu0 at one eps. Each iteration tries, side by side (no
    nested loop: cheap under vmap), the steps alpha (J - m I)^-1 (-r) for alpha = 2^-j,
    j < max_backtracks, and Levenberg-Marquardt shifts m from 1e-13 to 10 times max |J_ii|
    (Newton to gradient ascent: J is negative semidefinite), and takes, of those that satisfy
    Armijo's condition on g, the longest step of the smallest shift (backtracking with a
    Levenberg-Marquardt fallback), or the full Newton step if it halves |r|. Converged:
    max |r| <= tol, or max |r| <= 1e3 tol with a step below 1e-13 (1 + |nu|) (round-off
    floor). Stops when the ascent diverges (`_diverged`). Returns (nu, converged, iterations,
    max |r|, infeasible: all points at full thrust or divergence)."""
    opts = options
    alphas = 0.5 ** jnp.arange(opts.max_backtracks, dtype=d.dtype)
    shifts = jnp.asarray([1e-13, 1e-8, 1e-5, 1e-2, 10.0], d.dtype)
    g_at = jax.vmap(lambda nu: dual(nu, E, c, d, eps))

    def cond(s):
        return ~s.done & ~s.failed & (s.k < opts.max_newton)

    def body(s):
        nu, k = s.nu, s.k
        r = residual(nu, E, c, d, eps)
        J = jax.jacfwd(residual)(nu, E, c, d, eps)
        scale = jnp.max(jnp.abs(jnp.diag(J))) + 1e-300
        eye = jnp.eye(J.shape[0], dtype=J.dtype)
        # Newton steps with Levenberg-Marquardt shifts (J is negative semidefinite): from the
        # Newton step (shift 1e-13 scale) towards the gradient direction r / shift
        steps = jax.vmap(lambda m: small_spd_solve(m * scale * eye - J, r)[0])(shifts)
        slopes = steps @ r                                 # > 0: ascent directions of g
        g0 = dual(nu, E, c, d, eps)
        trial = nu + alphas[:, None, None] * steps[None]   # (n_alpha, n_shift, n_x)
        g = g_at(trial.reshape(-1, nu.shape[0])).reshape(alphas.shape[0], shifts.shape[0])
        ok = (g >= g0 + opts.armijo * alphas[:, None] * slopes[None]) & (slopes[None] > 0.0)
        ok &= jnp.isfinite(g)
        first = jnp.argmax(ok.T.reshape(-1))               # smallest shift, then longest step
        best = (first % alphas.shape[0]) * shifts.shape[0] + first // alphas.shape[0]
        # near the solution g's round-off hides the ascent: a full Newton step that halves
        # |r| is taken regardless (as `jaxlpm.nlp.newton` does with its KKT residual)
        full = (jnp.max(jnp.abs(residual(nu + steps[0], E, c, d, eps)))
                <= 0.5 * jnp.max(jnp.abs(r)))
        step = jnp.where(full, steps[0], trial.reshape(-1, nu.shape[0])[best] - nu)
        good = jnp.all(jnp.isfinite(step)) & (full | jnp.any(ok))
        nu_next = jnp.where(good, nu + step, nu)
        res = jnp.max(jnp.abs(residual(nu_next, E, c, d, eps)))
        tiny = jnp.max(jnp.abs(step)) <= 1e-13 * (1.0 + jnp.max(jnp.abs(nu)))
        done = (res <= opts.tol) | ((res <= 1e3 * opts.tol) & tiny)
        return _DualNewtonState(nu_next, k + 1, res, done, ~good | _diverged(nu_next, E, c))

    res0 = jnp.max(jnp.abs(residual(nu0, E, c, d, eps)))
    nu, k, res, done, _ = jax.lax.while_loop(
        cond, body, _DualNewtonState(nu0, 0, res0, res0 <= opts.tol, jnp.array(False)))
    w = jnp.linalg.norm(controls(nu, E, c, eps), axis=1)
    saturated = jnp.all(w >= 1.0 - 1e-9) | _diverged(nu, E, c)
    return nu, done & jnp.isfinite(res), k, res, saturated


def run_homotopy(E, c, d, nu0, options: HomotopyOptions) -> "HomotopyResult":
    """The homotopy (module docstring) from the eps = 1 guess nu0, traced (the body of
    `energy_to_fuel`, for solvers that run it inside their own loops)."""
    opts = options
    dtype = d.dtype
    nu_e, ok_e, k_e, res_e, sat_e = newton_dual(nu0, E, c, d, jnp.asarray(1.0, dtype), opts)
    first = jnp.where(ok_e, _RUNNING,
                      jnp.where(sat_e, Status.INFEASIBLE,
                                jnp.where(jnp.isfinite(res_e), Status.MAX_ITERATIONS,
                                          Status.NONFINITE))).astype(jnp.int32)
    eps_min = jnp.asarray(opts.eps_min, dtype)
    first = jnp.where((first == _RUNNING) & (eps_min >= 1.0), Status.SUCCESS, first)

    def body(s):
        nu, eps, step, n, fails, its, res, _ = s       # a _HomotopyState
        eps_try = jnp.maximum(eps * 10.0 ** (-step), eps_min)
        # the feasible set does not depend on eps, and the previous eps converged: a step
        # that fails here, even by a runaway ascent, is numerical (a smaller step), never
        # INFEASIBLE (a dispersed transfer at 37 % of its thrust had ended INFEASIBLE so)
        nu_t, ok, k, res_t, _ = newton_dual(nu, E, c, d, eps_try, opts)
        nu = jnp.where(ok, nu_t, nu)
        eps_new = jnp.where(ok, eps_try, eps)
        step_new = jnp.where(ok, jnp.minimum(2.0 * step, opts.max_step), 0.5 * step)
        status = jnp.select(
            [ok & (eps_try <= eps_min), ~ok & (step_new < opts.min_step),
             n + 1 >= opts.max_steps],
            [Status.SUCCESS, Status.STALLED, Status.MAX_ITERATIONS],
            _RUNNING).astype(jnp.int32)
        return _HomotopyState(nu, eps_new, step_new, n + 1, fails + (~ok).astype(jnp.int32),
                              its + k, jnp.where(ok, res_t, res), status)

    state = _HomotopyState(nu_e, jnp.asarray(1.0, dtype), jnp.asarray(opts.first_step, dtype),
                           0, 0, k_e, res_e, first)
    nu, eps, _, n, fails, its, res, status = jax.lax.while_loop(
        lambda s: s.status == _RUNNING, body, state)
    return HomotopyResult(nu=nu, eps=eps, nu_energy=nu_e, status=status, steps=n,
                          failed_steps=fails, newton_iterations=its, residual=res,
                          energy_residual=res_e)


@compiled(static_argnames="options")
def energy_to_fuel(E, c, d, nu0=None,
                   options: HomotopyOptions = HomotopyOptions()) -> HomotopyResult:
    """Run the homotopy for the condensed problem (E (m, n_x, 3), c (m,), d (n_x,); see the
    module docstring) from the eps = 1 guess nu0 (default 0). jit-compiled per shape and
    options; vmap-able."""
    return run_homotopy(E, c, d, jnp.zeros_like(d) if nu0 is None else nu0, options)


__all__ = ["HomotopyOptions", "HomotopyResult", "controls", "dual", "energy_to_fuel",
           "newton_dual", "primers", "residual", "run_homotopy"]
