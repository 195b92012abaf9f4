"""Fuel-optimal relative transfer with bounded thrust on HCW, and its energy-to-fuel smoothing
(Yue & Duan 2016, eq. 18-22 and 31-34; Bertrand & Epenoy 2002, "New smoothing techniques for
solving bang-bang optimal control problems", Optim. Control Appl. Meth. 23, 171-197).

    minimise    J_eps = (T_max / m) int_0^{t_f} [ w - eps w (1 - w) ] dt,   w = |u| / u_max
    subject to  x_dot = A_HCW x + B u,  |u| <= u_max = T_max / m,  x(0) = x0,  x(t_f) = xf
    LVLH frame (x radial out, y along-track, z orbit normal); m, m/s, m/s^2, s; T_max in N,
    m in kg held constant in the dynamics (the paper's eq. 1 assumption); t_f fixed.

eps = 1 is the energy-like problem (J_1 = int |u|^2 / u_max dt, with the thrust bound),
eps = 0 the fuel (Delta-v) problem, J_0 = int |u| dt. For 0 < eps <= 1 the integrand
(1 - eps) w + eps w^2 is strictly convex in w. With the primer vector p = -lambda_v (the
velocity costate, scaled so that the cost rate is u_max (.) and p . u / u_max its pairing)
and S = |p|, Pontryagin's minimum gives the direction p / S and the throttle (paper eq. 33-34
with the switching function rho = 1 - S):

    w = 0 if rho > eps,   w = 1 if rho < -eps,   w = (eps - rho) / (2 eps) otherwise.

The fuel mass is reported by the rocket equation m (1 - exp(-Delta v / (Isp g0))) (the paper's
eq. 2 is its first-order form F dt / (Isp g0), larger by a relative Delta v / (2 Isp g0)).

Inside the solver: s = n t (the chief's angle), lengths in L = max(|r0|, |rf|, 1 m),
accelerations in L n^2; `condensed_lgr` transcribes x' = A x + B u on a segmented LGR mesh and
eliminates the states, so the final state is affine in the controls: x_K = Phi x0 + sum_i E_i u_i.
"""

from dataclasses import dataclass, replace

import jax
import jax.numpy as jnp

from .._validation import Checked, Rule, coerce_sequences
from ..constants import G0
from ..dynamics import hcw_flow, hcw_matrix
from ..dynamics.linear import hcw_unit_rates
from ..linalg import dense_solve
from ..collocation.segments import LGRMesh, SegmentedMesh
from ..nlp.accuracy import check_flight, check_mesh, collocation_defects
from ..nlp.homotopy import controls, primers
from ..nlp.ocp import OptimalControlProblem
from ..orbits import KeplerOrbit
from ..solution import Segmented, Solution
from ..solution.accuracy import accuracy_stats
from ..status import Status
from .scaling import length_scale, state_scale


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class FuelOptimalTransfer(Checked):
    """Minimise the delta-v int |u| dt (m/s) from x0 to xf in `duration` with |u| bounded.

    orbit        the chief's circular `KeplerOrbit` (e = 0: HCW; SI, rad); t = 0 at its epoch
    x0, xf       LVLH states [x, y, z, vx, vy, vz] (m, m/s; x radial outward, y along-track,
                 z orbit normal)
    duration     t_f (s, fixed)
    thrust_max   the thrust bound T_max (N); u_max = T_max / mass (m/s^2)
    mass         the spacecraft's mass (kg, held constant in the dynamics)
    isp          specific impulse (s), for the propellant mass by the rocket equation
    """

    orbit: KeplerOrbit
    x0: jax.Array
    xf: jax.Array
    duration: jax.Array
    thrust_max: jax.Array
    mass: jax.Array
    isp: jax.Array

    SHAPES = {"x0": (6,), "xf": (6,), "duration": (), "thrust_max": (), "mass": (), "isp": ()}

    def __post_init__(self):
        coerce_sequences(self)

    def replace(self, **kwargs) -> "FuelOptimalTransfer":
        return replace(self, **kwargs)

    @property
    def max_acceleration(self):
        """u_max = T_max / m (m/s^2)."""
        return self.thrust_max / self.mass

    def rules(self):
        """Validity rules, written once (`jaxlpm._validation.Checked`)."""
        positive = [Rule(name, jnp.isfinite(getattr(self, name)) & (getattr(self, name) > 0.0),
                         f"positive and finite ({unit})")
                    for name, unit in (("duration", "s"), ("thrust_max", "N"), ("mass", "kg"),
                                       ("isp", "s"))]
        return [*self.orbit.rules(),
                Rule("orbit.e", self.orbit.e == 0.0,
                     "0: fuel-optimal transfers use the HCW equations (circular chief)"),
                Rule("x0", jnp.all(jnp.isfinite(self.x0)), "finite (m, m/s)"),
                Rule("xf", jnp.all(jnp.isfinite(self.xf)), "finite (m, m/s)"),
                *positive,
                Rule("xf", jnp.any(self.x0 != self.xf),
                     "different from x0 (the fuel-optimal transfer is no thrust at all)")]

    def harmless(self) -> "FuelOptimalTransfer":
        """A valid transfer (100 m along-track from rest in 5000 s, 1 N on 100 kg)."""
        return FuelOptimalTransfer(
            orbit=self.orbit.harmless(), x0=jnp.zeros(6),
            xf=jnp.array([0.0, 100.0, 0.0, 0.0, 0.0, 0.0]), duration=5000.0, thrust_max=1.0,
            mass=100.0, isp=300.0)


def check_fuel_problem(problem: FuelOptimalTransfer) -> None:
    """Validate at the Python boundary (everything when concrete, shapes when traced)."""
    if not isinstance(problem, FuelOptimalTransfer):
        raise ValueError(f"problem must be a FuelOptimalTransfer, got {type(problem).__name__}")
    problem.check()


def rocket_fuel(dv, problem: FuelOptimalTransfer):
    """Propellant mass (kg) for a Delta-v (m/s): m (1 - exp(-dv / (Isp g0)))."""
    return problem.mass * -jnp.expm1(-dv / (problem.isp * G0))


def hcw_input_matrices():
    """(A, B) of x' = A x + B u in the solver's units (s = n t, accelerations in L n^2)."""
    B = jnp.concatenate([jnp.zeros((3, 3)), jnp.eye(3)])
    return hcw_matrix(1.0), B


def _segment_maps(A, B, grid, h):
    """One LGR segment of half length h: the state rows X_r (n, n_x) after its first point,
    X_r = P_rows x_start + G_rows U, from the defects D X = h (A X_c + B U) (Garg et al. 2010)."""
    n, n_x, n_u = grid.n, A.shape[0], B.shape[1]
    d0, Dr = grid.D[:, 0], grid.D[:, 1:]
    shift = jnp.eye(n, k=-1)
    e0 = jnp.zeros(n).at[0].set(1.0)
    eye = jnp.eye(n_x)
    M = jnp.kron(Dr, eye) - h * jnp.kron(shift, A)
    rhs_x = -jnp.kron(d0[:, None], eye) + h * jnp.kron(e0[:, None], A)
    rhs_u = h * jnp.kron(jnp.eye(n), B)
    sol = dense_solve(M, jnp.concatenate([rhs_x, rhs_u], axis=1))
    P = sol[:, :n_x].reshape(n, n_x, n_x)
    G = sol[:, n_x:].reshape(n, n_x, n, n_u)
    return P, G


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class CondensedLGR:
    """Segmented LGR transcription of x' = A x + B u with the states eliminated.

    P (K, n, n_x, n_x), G (K, n, n_x, n, n_u): state rows after each segment's first point,
    X_r,k = P_k x_k + G_k U_k (the last row is the next segment's first state x_{k+1});
    Phi (n_x, n_x) and E (K, n, n_x, n_u): x_K = Phi x_0 + sum_{k,i} E_{k,i} U_{k,i}.
    """

    P: jax.Array
    G: jax.Array
    Phi: jax.Array
    E: jax.Array

    def states(self, x0, U):
        """All state rows (K, n + 1, n_x) (first point, then X_r) for controls U (K, n, n_u)."""
        def step(x, pg):
            P, G, u = pg
            rows = P @ x + jnp.einsum("iajb,jb->ia", G, u)
            return rows[-1], jnp.concatenate([x[None], rows])
        _, X = jax.lax.scan(step, x0, (self.P, self.G, U))
        return X


def condensed_lgr(A, B, mesh) -> CondensedLGR:
    """Transcribe x' = A x + B u on a `SegmentedMesh` and eliminate the states (see
    `CondensedLGR`); continuity across segments is exact (shared break states)."""
    P, G = jax.vmap(lambda h: _segment_maps(A, B, mesh.grid, h))(mesh.half_lengths)
    P_end, G_end = P[:, -1], G[:, -1]                      # (K, n_x, n_x), (K, n_x, n, n_u)

    def back(Psi, pg):
        P_k, G_k = pg
        return Psi @ P_k, jnp.einsum("ab,bjc->jac", Psi, G_k)

    Phi, E = jax.lax.scan(back, jnp.eye(A.shape[0]), (P_end, G_end), reverse=True)
    return CondensedLGR(P=P, G=G, Phi=Phi, E=E)


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class FuelNLP:
    """The transcribed problem handed to `jaxlpm.nlp.homotopy.energy_to_fuel`: minimise
    sum_i c_i l_eps(|v_i|) subject to sum_i E_i v_i = d, |v_i| <= 1 (v = u / u_max at the
    collocation points), with what maps its solution back to SI.

    E (K n, 6, 3), c (K n,), d (6,); cond: the `CondensedLGR` of the mesh in s = n t;
    mesh_s: the mesh with breaks in s; x0, xf: scaled boundary states; umax: u_max in L n^2.
    """

    E: jax.Array
    c: jax.Array
    d: jax.Array
    cond: CondensedLGR
    mesh_s: object
    x0: jax.Array
    xf: jax.Array
    umax: jax.Array


def to_nlp(problem: FuelOptimalTransfer, mesh) -> FuelNLP:
    """The problem on `mesh` (breaks as fractions of the duration) as a `FuelNLP`: HCW in
    s = n t, lengths in L, the states eliminated by the condensed LGR transcription."""
    n = problem.orbit.mean_motion
    scale = state_scale(problem)
    umax = problem.max_acceleration / (length_scale(problem) * n**2)
    mesh_s = SegmentedMesh(breaks=mesh.breaks * n * problem.duration, grid=mesh.grid)
    cond = condensed_lgr(*hcw_input_matrices(), mesh_s)
    x0, xf = problem.x0 / scale, problem.xf / scale
    K, npts = mesh_s.n_segments, mesh_s.grid.n
    return FuelNLP(E=umax * cond.E.reshape(K * npts, 6, 3), c=umax * mesh_s.weights.reshape(-1),
                   d=xf - cond.Phi @ x0, cond=cond, mesh_s=mesh_s, x0=x0, xf=xf, umax=umax)


def _thrust_bound(s, x, u, data, p):
    return (jnp.linalg.norm(u) - p["umax"])[None]


def collocation_accuracy(problem: FuelOptimalTransfer, nlp: FuelNLP, X, U):
    """`jaxlpm.solution.accuracy` stats (SI, LVLH) of the solution with state rows X
    (K, n + 1, 6) and controls U (K, n, 3) in the solver's units: the GPOPS-II estimate and
    the check-mesh flight of the control interpolated segment by segment (what `verify.fly`
    flies), on the mesh seen as one `LGRMesh` in tau = 2 s / s_f - 1. path_violation is the
    delta-v the engine cannot deliver, int max(|u| - u_max, 0) dt (m/s, the check mesh's
    quadrature): what clipping the interpolated control to the bound changes the velocity
    by at most (the interpolant overshoots the bound between the nodes where a segment holds
    a switch)."""
    m = nlp.mesh_s
    K, npts = m.n_segments, m.grid.n
    sf = m.breaks[-1]
    grid = LGRMesh(breaks=2.0 * m.breaks / sf - 1.0, segment=m.grid)
    rows = jnp.concatenate([X[:, :npts].reshape(K * npts, 6), X[-1, -1:]])
    check = check_mesh(grid)
    ocp = OptimalControlProblem(n_x=6, n_u=3, dynamics=hcw_unit_rates, s0=jnp.zeros_like(sf),
                                sf=sf, params={"umax": nlp.umax}, path=_thrust_bound)
    U = U.reshape(K * npts, 3)
    d = collocation_defects(ocp, check, grid, rows, U)
    flown = check_flight(ocp, check, grid, rows, U, newton_steps=1)    # linear: exact
    excess = jnp.sum(check.weights * jnp.maximum(d.path[:, 0], 0.0)) * 0.5 * sf
    return accuracy_stats((flown - d.states) * state_scale(problem), d.relative,
                          excess * length_scale(problem) * problem.orbit.mean_motion)


def to_solution(problem: FuelOptimalTransfer, mesh, nlp: FuelNLP, res, valid):
    """The `Solution` (SI, LVLH; `Segmented` on `mesh`) of the homotopy's result `res`: the
    eps-smoothed optimum's controls and states, cost = delta-v int |u| dt (m/s), costates
    dJ/dx(s) = L n exp(A (s_f - s))^T nu / scale (the final-state multipliers nu: the exact
    adjoint of the condensed problem, module docstring), zeros where `valid` is False.

    stats: node_throttle |u| / u_max, node_primers (the primer at the points), fuel (kg),
    the eps = 1 energy-like solution on the same mesh (energy_node_controls m/s^2,
    energy_dv m/s, energy_fuel kg, energy_cost 1/2 int |u|^2 dt m^2/s^3), eps,
    multipliers nu and energy_multipliers (solver units), terminal_error and
    energy_terminal_error [m, m/s] of the collocated final state, homotopy_steps,
    failed_steps, newton_iterations; the error estimate (`collocation_accuracy`:
    error_position m, error_velocity m/s, relative_error, segment_error, path_violation
    m/s)."""
    def keep(x):
        return jnp.where(valid, x, jnp.zeros_like(x))

    n, L = problem.orbit.mean_motion, length_scale(problem)
    scale = state_scale(problem)
    m, E, c = nlp.mesh_s, nlp.E, nlp.c
    K, npts = m.n_segments, m.grid.n

    def outputs(nu, eps):
        v = controls(nu, E, c, eps)
        U = (nlp.umax * v).reshape(K, npts, 3)
        X = nlp.cond.states(nlp.x0, U)
        miss = (X[-1, -1] - nlp.xf) * scale
        err = jnp.stack([jnp.linalg.norm(miss[:3]), jnp.linalg.norm(miss[3:])])
        return v, U, X, jnp.sum(c * jnp.linalg.norm(v, axis=1)) * L * n, err

    v, U, X, dv, err = outputs(res.nu, res.eps)
    ve, Ue, _, dve, erre = outputs(res.nu_energy, jnp.asarray(1.0, nlp.d.dtype))
    a_si = L * n**2
    energy_cost = 0.5 * jnp.sum(c * jnp.sum((nlp.umax * ve) ** 2, axis=1) / nlp.umax) \
        * a_si**2 / n
    sf = m.breaks[-1]
    lam = jax.vmap(lambda s: hcw_flow(sf - s).T @ res.nu)(m.points.reshape(-1))
    duration = problem.duration + 0.0 * dv
    trajectory = Segmented(
        mesh=mesh, duration=duration, times=keep(m.points / n), node_controls=keep(U * a_si),
        node_costates=keep((L * n * lam / scale).reshape(K, npts, 6)),
        state_times=keep(m.state_points / n), node_states=keep(X * scale))
    return Solution(
        problem=problem, status=jnp.where(valid, res.status, Status.INVALID_INPUT).astype(
            jnp.int32),
        cost=keep(dv), duration=duration, trajectory=trajectory,
        stats=dict(node_throttle=keep(jnp.linalg.norm(v, axis=1).reshape(K, npts)),
                   node_primers=keep(primers(res.nu, E, c).reshape(K, npts, 3)),
                   fuel=keep(rocket_fuel(dv, problem)),
                   energy_node_controls=keep(Ue * a_si), energy_dv=keep(dve),
                   energy_fuel=keep(rocket_fuel(dve, problem)), energy_cost=keep(energy_cost),
                   eps=res.eps, multipliers=keep(res.nu), energy_multipliers=keep(res.nu_energy),
                   terminal_error=keep(err), energy_terminal_error=keep(erre),
                   homotopy_steps=res.steps, failed_steps=res.failed_steps,
                   newton_iterations=res.newton_iterations,
                   **collocation_accuracy(problem, nlp, X, U)),
        method="homotopy")
