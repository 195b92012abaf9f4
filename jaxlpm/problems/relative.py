"""`EnergyOptimalTransfer` written as an `OptimalControlProblem` in the chief's anomaly.

Independent variable s: the chief's true anomaly f (models "linear", "two-body") or its
regularised anomaly s = f0 + int |h|/r^2 dt (model "j2"); s runs from f0 to the anomaly reached
after the transfer's duration. Collocating in s rather than time keeps the orbital harmonics of
an eccentric chief low-degree polynomials (Mei 2010 §2; the time-domain alternative loses
several digits at N = 64, e = 0.3 over 3 revolutions).

Scaling (users pass SI; the solver sees O(1) numbers): length L = max(|r0|, |rf|, 1 m),
n = the chief's mean motion.
  "linear":  Tschauner-Hempel state x~/L (Mei 2010 eq. 1, 11), control U = u / (k^4 L),
             cost 1/2 int |U|^2 / rho^2 df: the KKT law's own transcription (Mei eq. 12-16);
             J_SI = k^6 L^2 J, k^2 = sqrt(mu / p^3).
  "two-body", "j2":  LVLH state [rho / L, rho_dot / (L n)], control u / (L n^2),
             dx/ds = q [rho_dot, rho_ddot] / (L n, L n^2) with q = n dt/ds and rho_ddot from
             `relative_lvlh_acceleration` (exact, nonlinear), the chief's frame motion
             (C, w, w_dot) sampled once per collocation point; cost 1/2 int q |u~|^2 ds;
             J_SI = L^2 n^3 J.
A removed thrust axis (`thrust_axes`) multiplies its control by 0 in the dynamics; the cost then
drives that component to exactly 0.
"""

import jax
import jax.numpy as jnp

from ..dynamics import (lvlh_frame_motion, relative_lvlh_acceleration,
                        tschauner_hempel_matrix)
from ..dynamics.chief import (anomaly_rate, j2_chief, j2_final_anomaly, kepler_chief,
                              kepler_final_anomaly)
from ..orbits import lvlh_to_th, th_to_lvlh
from ..nlp.ocp import OptimalControlProblem
from ..nlp.transcription import collocated_rows, state_tau
from .transfer import EnergyOptimalTransfer


def length_scale(problem: EnergyOptimalTransfer):
    """L = max(|r0|, |rf|, 1 m)."""
    return jnp.maximum(jnp.maximum(jnp.linalg.norm(problem.x0[:3]),
                                   jnp.linalg.norm(problem.xf[:3])), 1.0)


def _th_dynamics(s, x, u, data, p):
    return tschauner_hempel_matrix(s, p["e"]) @ x + jnp.concatenate(
        [jnp.zeros(3), p["axes"] * u / (1.0 + p["e"] * jnp.cos(s)) ** 3])


def _th_cost(s, x, u, data, p):
    return 0.5 * jnp.dot(u, u) / (1.0 + p["e"] * jnp.cos(s)) ** 2


def _lvlh_dynamics(s, x, u, data, p):
    r_chief, frame, q = data
    L, n = p["length"], p["n"]
    x_si = x * jnp.concatenate([jnp.full(3, L), jnp.full(3, L * n)])
    u_si = p["axes"] * u * (L * n * n)
    acc = relative_lvlh_acceleration(r_chief, frame, x_si, u_si, p["mu"], p["j2"], p["r_eq"])
    return q * jnp.concatenate([x[3:], acc / (L * n * n)])


def _lvlh_cost(s, x, u, data, p):
    return 0.5 * data[-1] * jnp.dot(u, u)


def _fixed_ends(x0, xf, sf, p):
    return jnp.concatenate([x0 - p["x0"], xf - p["xf"]])


def final_anomaly(problem: EnergyOptimalTransfer):
    """(s_f, ok): the anomaly at the end of the transfer."""
    o = problem.orbit
    if problem.model == "j2":
        return j2_final_anomaly(o, problem.duration, problem.j2, problem.r_eq)
    return kepler_final_anomaly(o, problem.duration), jnp.array(True)


def chief_at(problem: EnergyOptimalTransfer, s_f, tau):
    """(ChiefSamples at tau in [-1, 1] of [f0, s_f], ok)."""
    o = problem.orbit
    if problem.model == "j2":
        return j2_chief(o, s_f, 0.5 * (tau + 1.0), problem.j2, problem.r_eq)
    return kepler_chief(o, o.f0 + 0.5 * (s_f - o.f0) * (tau + 1.0)), jnp.array(True)


def model_state(problem: EnergyOptimalTransfer, x_lvlh, s):
    """LVLH state (m, m/s) at anomaly s -> the solver's scaled state."""
    o, L = problem.orbit, length_scale(problem)
    if problem.model == "linear":
        return lvlh_to_th(x_lvlh, s, o.e, o.k2) / L
    return x_lvlh / jnp.concatenate([jnp.full(3, L), jnp.full(3, L * o.mean_motion)])


def lvlh_state(problem: EnergyOptimalTransfer, x, s):
    """Inverse of `model_state`."""
    o, L = problem.orbit, length_scale(problem)
    if problem.model == "linear":
        return th_to_lvlh(x * L, s, o.e, o.k2)
    return x * jnp.concatenate([jnp.full(3, L), jnp.full(3, L * o.mean_motion)])


def control_scale(problem: EnergyOptimalTransfer):
    """u (m/s^2) = control_scale * the solver's control."""
    o, L = problem.orbit, length_scale(problem)
    return L * (o.k2**2 if problem.model == "linear" else o.mean_motion**2)


def cost_scale(problem: EnergyOptimalTransfer):
    """1/2 int |u|^2 dt (m^2/s^3) = cost_scale * the solver's cost."""
    o, L = problem.orbit, length_scale(problem)
    return L**2 * (o.k2**3 if problem.model == "linear" else o.mean_motion**3)


def transfer_ocp(problem: EnergyOptimalTransfer, grid):
    """The transfer as an `OptimalControlProblem` on `grid`, with the chief sampled at the
    state rows (`ChiefSamples`, for times and the LVLH map) and an integration flag ok."""
    o = problem.orbit
    s_f, ok_f = final_anomaly(problem)
    chief, ok_c = chief_at(problem, s_f, state_tau(grid))
    x0 = model_state(problem, problem.x0, o.f0)
    xf = model_state(problem, problem.xf, s_f)
    axes = jnp.asarray(problem.thrust_axes, x0.dtype)
    params = {"x0": x0, "xf": xf, "e": o.e, "axes": axes}
    if problem.model == "linear":
        dynamics, cost, data = _th_dynamics, _th_cost, None
    else:
        states = chief.state[collocated_rows(grid)]
        q = o.mean_motion / jax.vmap(anomaly_rate)(states)
        j2 = problem.j2 if problem.model == "j2" else 0.0 * problem.j2
        frames = jax.vmap(lvlh_frame_motion, in_axes=(0, None, None, None))(
            states, o.mu, j2, problem.r_eq)
        data = (states[:, :3], frames, q)
        params.update(length=length_scale(problem), n=o.mean_motion, mu=o.mu, j2=j2,
                      r_eq=problem.r_eq)
        dynamics, cost = _lvlh_dynamics, _lvlh_cost
    ocp = OptimalControlProblem(
        n_x=6, n_u=3, dynamics=dynamics, running_cost=cost, boundary=_fixed_ends,
        s0=o.f0 + 0.0 * s_f, sf=s_f, params=params, node_data=data)
    return ocp, chief, ok_f & ok_c
