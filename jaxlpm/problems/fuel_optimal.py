"""Fuel-optimal relative transfer with bounded thrust, and its energy-to-fuel smoothing (Yue &
Duan 2016, eq. 18-22 and 31-34; Bertrand & Epenoy 2002, "New smoothing techniques for solving
bang-bang optimal control problems", Optim. Control Appl. Meth. 23, 171-197), on the dynamics
models of the energy-optimal transfers.

    minimise    J_eps = u_max int_0^{t_f} [ w - eps w (1 - w) ] dt,   w = |u| / u_max
    subject to  the relative dynamics of `model`,  |u| <= u_max = T_max / m,
                x(0) = x0, x(t_f) = xf
    LVLH frame (x radial out, y along-track, z orbit normal); m, m/s, m/s^2, s; T_max in N,
    m in kg held constant in the dynamics (the paper's eq. 1 assumption); t_f fixed.

models (`jaxlpm.problems.energy_optimal`): "linear" (Tschauner-Hempel about a Keplerian chief;
HCW at e = 0), "two-body", "j2". The transcription is the energy-optimal transfer's
(`transfer_ocp`) in the same independent variable s (the chief's true anomaly, or the J2
chief's regularised anomaly), on a segmented LGR or LG mesh (Garg et al. 2010) whose breaks
are fractions of [s0, s_f] (of the duration on a circular chief).

eps = 1 is the energy-like problem (J_1 = int |u|^2 / u_max dt, with the thrust bound),
eps = 0 the fuel (Delta-v) problem, J_0 = int |u| dt. For 0 < eps <= 1 the integrand
(1 - eps) w + eps w^2 is strictly convex in w. With the primer vector p = -lambda_v / (n dt/ds)
(the velocity costate per unit of the cost rate) and S = |p|, Pontryagin's minimum gives the
direction p / S and the throttle (paper eq. 33-34 with the switching function rho = 1 - S):

    w = 0 if rho > eps,   w = 1 if rho < -eps,   w = (eps - rho) / (2 eps) otherwise.

The fuel mass is reported by the rocket equation m (1 - exp(-Delta v / (Isp g0))) (the paper's
eq. 2 is its first-order form F dt / (Isp g0), larger by a relative Delta v / (2 Isp g0)).

Condensed transcription (`condensed_mesh`): the dynamics linearised at the collocation points,
x' = A_i x + B_i u + c_i (exact for the linear model; about a reference trajectory for the
nonlinear ones, `linearised_nlp`), collocated on each LGR or LG segment and the states
eliminated, so the final state is affine in the controls: x_K = Phi x0 + sum_i E_i u_i + o.
The solver (`jaxlpm.solvers.fuel_optimal`) relinearises the nonlinear models about each
solution until the state rows stop moving: the fixed point satisfies the nonlinear collocation
equations, and its KKT conditions are the nonlinear problem's (the linearisation has the same
Jacobians there).
"""

from dataclasses import dataclass, field, replace

import jax
import jax.numpy as jnp

from .._validation import Checked, Rule, array_module, coerce_sequences
from ..collocation.segments import Mesh, SegmentedMesh, tau_mesh
from ..constants import G0, J2_EARTH, R_EARTH
from ..dynamics.chief import anomaly_rate
from ..linalg import dense_solve
from ..nlp.homotopy import controls, primers
from ..nlp.transcription import collocated_rows, collocation_s
from ..orbits import KeplerOrbit
from ..solution import Collocated, Solution, zero_invalid
from . import safety
from .scaling import safe_norm
from .energy_optimal import (MODELS, EnergyOptimalTransfer, collocation_accuracy,
                             control_scale, lvlh_state, model_state, transfer_ocp)


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class FuelOptimalTransfer(Checked):
    """Minimise the delta-v int |u| dt (m/s) from x0 to xf in `duration` with |u| bounded.

    orbit        the chief's `KeplerOrbit` (SI, rad); the transfer starts at its epoch
    x0, xf       LVLH states [x, y, z, vx, vy, vz] (m, m/s; x radial outward, y along-track,
                 z orbit normal)
    duration     t_f (s, fixed)
    thrust_max   the thrust bound T_max (N); u_max = T_max / mass (m/s^2)
    mass         the spacecraft's mass (kg, held constant in the dynamics)
    isp          specific impulse (s), for the propellant mass by the rocket equation
    model        "linear" (Tschauner-Hempel; HCW on a circular chief), "two-body" or "j2"
                 (static; `jaxlpm.problems.energy_optimal`)
    j2, r_eq     the J2 coefficient and equatorial radius (m) of the "j2" model
    constraints  safety constraints in SI (LVLH about the target; `jaxlpm.problems.safety`:
                 `KeepOutEllipsoid`, `ApproachCone`, `SpeedLimit`, `PassiveSafety`; the
                 thrust bound is the family's own), a tuple (default none); with any, the
                 method is "augmented-lagrangian" (`jaxlpm.solvers.fuel_constrained`)
    """

    orbit: KeplerOrbit
    x0: jax.Array
    xf: jax.Array
    duration: jax.Array
    thrust_max: jax.Array
    mass: jax.Array
    isp: jax.Array
    model: str = field(default="linear", metadata=dict(static=True))
    j2: jax.Array = J2_EARTH
    r_eq: jax.Array = R_EARTH
    constraints: tuple = field(default=(), metadata=dict(tree=True))

    SHAPES = {"x0": (6,), "xf": (6,), "duration": (), "thrust_max": (), "mass": (), "isp": (),
              "j2": (), "r_eq": ()}

    def __post_init__(self):
        coerce_sequences(self)
        if isinstance(self.constraints, list):
            object.__setattr__(self, "constraints", tuple(self.constraints))

    def replace(self, **kwargs) -> "FuelOptimalTransfer":
        return replace(self, **kwargs)

    @property
    def max_acceleration(self):
        """u_max = T_max / m (m/s^2)."""
        return self.thrust_max / self.mass

    def energy_problem(self, constraints=()) -> EnergyOptimalTransfer:
        """The energy-optimal transfer between the same states on the same model (its
        transcription, scaling and accuracy check are this family's too)."""
        return EnergyOptimalTransfer(self.orbit, self.x0, self.xf, self.duration,
                                     model=self.model, j2=self.j2, r_eq=self.r_eq,
                                     constraints=constraints)

    def rules(self):
        """Validity rules, written once (`jaxlpm._validation.Checked`): the energy-optimal
        transfer's (orbit, states, duration, model constants), then the engine's."""
        xp = array_module(self)
        positive = [Rule(name, xp.isfinite(getattr(self, name)) & (getattr(self, name) > 0.0),
                         f"positive and finite ({unit})")
                    for name, unit in (("thrust_max", "N"), ("mass", "kg"), ("isp", "s"))]
        return [*self.energy_problem(self.constraints).rules(), *positive,
                Rule("xf", xp.any(self.x0 != self.xf),
                     "different from x0 (the fuel-optimal transfer is no thrust at all)")]

    def static_rules(self) -> None:
        """The model, then the fields' shapes (`Checked.static_rules`)."""
        if self.model not in MODELS:
            raise ValueError(f"model must be one of {MODELS}, got {self.model!r}")
        for i, c in enumerate(safety.check_constraints(self.constraints)):
            if isinstance(c, safety.ThrustLimit):
                raise ValueError(f"constraints[{i}]: a fuel-optimal transfer's thrust bound is "
                                 f"its thrust_max / mass, not a ThrustLimit")
            c.static_rules()
        super().static_rules()

    def harmless(self) -> "FuelOptimalTransfer":
        """A valid transfer of the same model (100 m along-track from rest in 5000 s, 1 N on
        100 kg, about a circular orbit)."""
        return FuelOptimalTransfer(
            orbit=self.orbit.harmless(), x0=jnp.zeros(6),
            xf=jnp.array([0.0, 100.0, 0.0, 0.0, 0.0, 0.0]), duration=5000.0, thrust_max=1.0,
            mass=100.0, isp=300.0, model=self.model, j2=0.0, r_eq=R_EARTH,
            constraints=tuple(c.harmless() for c in self.constraints))


def check_fuel_problem(problem: FuelOptimalTransfer) -> None:
    """Validate at the Python boundary (everything when concrete, shapes when traced)."""
    if not isinstance(problem, FuelOptimalTransfer):
        raise ValueError(f"problem must be a FuelOptimalTransfer, got {type(problem).__name__}")
    problem.check()


def rocket_fuel(dv, problem: FuelOptimalTransfer):
    """Propellant mass (kg) for a Delta-v (m/s): m (1 - exp(-dv / (Isp g0)))."""
    return problem.mass * -jnp.expm1(-dv / (problem.isp * G0))


def _segment_maps(A, B, c, grid, h):
    """One LGR or LG segment of half length h with x' = A_i x + B_i u + c_i at its n points
    (A (n, n_x, n_x), B (n, n_x, n_u), c (n, n_x)): the state rows X_r after its start x,
    X_r = P x + G U + g, and M, the matrix of its equations in X_r (for the discrete adjoint).

    LGR (Garg et al. 2010's Radau method): X_r is the n - 1 points after the first and the
    end, from the n defects D X = h (A_i X_i + B_i U_i + c_i) (point 0 is the start).
    LG (Garg et al. 2010's Gauss method; Benson et al. 2006): X_r is the n Gauss points, from
    their n defects, and the end x_e = x + h sum_i w_i (A_i X_i + B_i U_i + c_i) (the
    quadrature row, last)."""
    n, n_x, n_u = grid.n, A.shape[-1], B.shape[-1]
    d0, Dr = grid.D[:, 0], grid.D[:, 1:]
    eye = jnp.eye(n_x)
    blocks = lambda m: m.transpose(0, 2, 1, 3).reshape(m.shape[0] * n_x, -1)  # noqa: E731
    rhs_u = h * jnp.einsum("ij,iab->iajb", jnp.eye(n), B).reshape(n * n_x, n * n_u)
    rhs_c = h * c.reshape(n * n_x, 1)
    rhs_x = -jnp.kron(d0[:, None], eye)
    if grid.scheme == "LGR":
        # point i >= 1 is state row i - 1 of X_r: the block sub-diagonal of A_i
        below = jnp.zeros((n, n, n_x, n_x)).at[jnp.arange(1, n), jnp.arange(n - 1)].set(A[1:])
        M = jnp.kron(Dr, eye) - h * blocks(below)
        rhs_x = rhs_x + h * jnp.zeros((n, n_x, n_x)).at[0].set(A[0]).reshape(n * n_x, n_x)
    else:
        w = jnp.asarray(grid.weights)
        diagonal = jnp.zeros((n, n, n_x, n_x)).at[jnp.arange(n), jnp.arange(n)].set(A)
        quadrature = jnp.concatenate(
            [-h * (w[:, None, None] * A).transpose(1, 0, 2).reshape(n_x, n * n_x), eye], axis=1)
        M = jnp.concatenate([jnp.concatenate([jnp.kron(Dr, eye) - h * blocks(diagonal),
                                              jnp.zeros((n * n_x, n_x))], axis=1),
                             quadrature])
        rhs_x = jnp.concatenate([rhs_x, eye])
        rhs_u = jnp.concatenate(
            [rhs_u, h * (w[:, None, None] * B).transpose(1, 0, 2).reshape(n_x, n * n_u)])
        rhs_c = jnp.concatenate([rhs_c, h * (w @ c)[:, None]])
    rows = M.shape[0] // n_x
    sol = dense_solve(M, jnp.concatenate([rhs_x, rhs_u, rhs_c], axis=1))
    P = sol[:, :n_x].reshape(rows, n_x, n_x)
    G = sol[:, n_x:n_x + n * n_u].reshape(rows, n_x, n, n_u)
    return P, G, sol[:, -1].reshape(rows, n_x), M


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class CondensedMesh:
    """Segmented LGR or LG transcription of x' = A_i x + B_i u + c_i with the states
    eliminated (`_segment_maps`); r rows after each segment's start (LGR r = n, LG r = n + 1).

    P (K, r, n_x, n_x), G (K, r, n_x, n, n_u), g (K, r, n_x): state rows after each segment's
    start, X_r,k = P_k x_k + G_k U_k + g_k (the last row is the next segment's start x_{k+1});
    Phi (n_x, n_x), E (K, n, n_x, n_u) and o (n_x):
    x_K = Phi x_0 + sum_{k,i} E_{k,i} U_{k,i} + o; Psi (K, n_x, n_x) = d x_K / d x_{k+1}
    (the sensitivity of the final state to each segment's end); M (K, r n_x, r n_x) the
    segments' equations in X_r; weights (n,) the segment grid's quadrature weights; scheme
    "LGR" or "LG" (static).
    """

    P: jax.Array
    G: jax.Array
    g: jax.Array
    Phi: jax.Array
    E: jax.Array
    o: jax.Array
    Psi: jax.Array
    M: jax.Array
    weights: jax.Array
    scheme: str = field(metadata=dict(static=True))

    def states(self, x0, U):
        """Every segment's state rows (K, r + 1, n_x) (its start, then X_r) for controls U
        (K, n, n_u)."""
        def step(x, pgu):
            P, G, g, u = pgu
            rows = P @ x + jnp.einsum("iajb,jb->ia", G, u) + g
            return rows[-1], jnp.concatenate([x[None], rows])
        _, X = jax.lax.scan(step, x0, (self.P, self.G, self.g, U))
        return X

    def collocation_rows(self, X):
        """The collocation points' states (K n, n_x) of `states`' rows X (LGR: each segment's
        first n rows; LG: its Gauss points, after its start)."""
        n = self.E.shape[1]
        first = 0 if self.scheme == "LGR" else 1
        return X[:, first:first + n].reshape(-1, X.shape[-1])

    def mesh_rows(self, X):
        """`states`' rows X in the layout of the mesh's state rows (`LGRMesh`, `LGMesh`): each
        segment's rows before the next segment's start, then the final state."""
        return jnp.concatenate([X[:, :-1].reshape(-1, X.shape[-1]), X[-1, -1:]])

    def costates(self, nu):
        """The costate estimates (K, n, n_x) at the collocation points of the final-state
        multiplier nu, from the multipliers Lambda_k = M_k^-T (e_last x Psi_k^T nu) of each
        segment's equations: LGR lambda_i = Lambda_i / w_i, LG lambda_i = Lambda_i / w_i +
        Lambda_e (Lambda_e the quadrature row's) (Garg et al. 2010, the Radau and Gauss
        costate estimates), so that E_i^T nu = h_k w_i B_i^T lambda_i either way; they
        approximate lambda(s_i) = Phi(s_f, s_i)^T nu."""
        n_x, n = self.Phi.shape[0], self.E.shape[1]

        def one(M, Psi):
            last = jnp.zeros((M.shape[0] // n_x, n_x)).at[-1].set(Psi.T @ nu).reshape(-1)
            lam = dense_solve(M.T, last[:, None])[:, 0].reshape(-1, n_x)
            points = lam[:n] / self.weights[:, None]
            return points if self.scheme == "LGR" else points + lam[n]
        return jax.vmap(one)(self.M, self.Psi)


def condensed_mesh(A, B, mesh: SegmentedMesh, c=None) -> CondensedMesh:
    """Transcribe x' = A x + B u + c on a `SegmentedMesh` (LGR or LG) and eliminate the
    states (see `CondensedMesh`). A (n_x, n_x) and B (n_x, n_u) constant, or per collocation
    point (K, n, n_x, n_x) and (K, n, n_x, n_u); c (K, n, n_x) or None (0). Continuity
    across segments is exact (each segment starts from the previous one's end)."""
    K, n = mesh.n_segments, mesh.grid.n
    n_x, n_u = A.shape[-1], B.shape[-1]
    A = jnp.broadcast_to(A, (K, n, n_x, n_x))
    B = jnp.broadcast_to(B, (K, n, n_x, n_u))
    c = jnp.zeros((K, n, n_x), A.dtype) if c is None else c
    P, G, g, M = jax.vmap(lambda a, b, ci, h: _segment_maps(a, b, ci, mesh.grid, h))(
        A, B, c, mesh.half_lengths)
    P_end, G_end, g_end = P[:, -1], G[:, -1], g[:, -1]    # (K, n_x, n_x), (K, n_x, n, n_u)

    def back(Psi, pg):
        P_k, G_k, g_k = pg
        return Psi @ P_k, (Psi, jnp.einsum("ab,bjc->jac", Psi, G_k), Psi @ g_k)

    Phi, (Psi, E, o) = jax.lax.scan(back, jnp.eye(n_x), (P_end, G_end, g_end), reverse=True)
    return CondensedMesh(P=P, G=G, g=g, Phi=Phi, E=E, o=jnp.sum(o, axis=0), Psi=Psi, M=M,
                         weights=jnp.asarray(mesh.grid.weights), scheme=mesh.grid.scheme)


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class FuelNLP:
    """The transcribed problem handed to `jaxlpm.nlp.homotopy.energy_to_fuel`: minimise
    sum_i c_i l_eps(|v_i|) subject to sum_i E_i v_i = d, |v_i| <= 1 (v = u / u_max at the
    collocation points), with what maps its solution back.

    E (K n, 6, 3), c (K n,), d (6,); cond: the `CondensedMesh` in s (the solver's units of
    `transfer_ocp`); mesh_s: the mesh with breaks in s; x0, xf: scaled boundary states;
    umax: u_max in the solver's control unit; rate: n dt/ds at the points (K n,).
    """

    E: jax.Array
    c: jax.Array
    d: jax.Array
    cond: CondensedMesh
    mesh_s: SegmentedMesh
    x0: jax.Array
    xf: jax.Array
    umax: jax.Array
    rate: jax.Array

    def controls(self, nu, eps):
        """The solver's controls U (K, n, 3) of the multipliers nu at smoothing eps."""
        K, n = self.mesh_s.n_segments, self.mesh_s.grid.n
        return (self.umax * controls(nu, self.E, self.c, eps)).reshape(K, n, 3)

    def states(self, nu, eps):
        """Every segment's state rows (`CondensedMesh.states`) that those controls give."""
        return self.cond.states(self.x0, self.controls(nu, eps))


@dataclass(frozen=True)
class Transcription:
    """The problem on a mesh (built once per solve, not a pytree): the energy-optimal
    transfer's `OptimalControlProblem` `ocp` on the `LGRMesh` or `LGMesh` `grid` (the same
    mesh in tau), its chief samples `chief` at the state rows, and the chief integration's
    flag `ok`; s_f and check_chief (the chief at the check mesh's rows, with its flag) where
    `transcribe` was given them (`transfer_chief`), else None."""

    problem: FuelOptimalTransfer
    mesh: SegmentedMesh
    ocp: object
    grid: Mesh
    chief: object
    ok: jax.Array
    s_f: object = None
    check_chief: object = None

    def linearised(self, Xc) -> FuelNLP:
        """The condensed problem with the dynamics linearised at the collocation-point states
        Xc (K n, 6) (the solver's units; exact, whatever Xc, on the linear model)."""
        problem, ocp, grid = self.problem, self.ocp, self.grid
        K, n = self.mesh.n_segments, self.mesh.grid.n
        s = collocation_s(ocp, grid)

        def f(si, x, u, d):
            return ocp.dynamics(si, x, u, d, ocp.params)

        def lin(si, x, d):
            u = jnp.zeros(3, x.dtype)
            A, B = jax.jacfwd(f, argnums=(1, 2))(si, x, u, d)
            return A, B, f(si, x, u, d) - A @ x

        A, B, c = jax.vmap(lin)(s, Xc, ocp.node_data)
        mesh_s = SegmentedMesh(breaks=ocp.s0 + (ocp.sf - ocp.s0) * self.mesh.breaks,
                               grid=self.mesh.grid)
        cond = condensed_mesh(A.reshape(K, n, 6, 6), B.reshape(K, n, 6, 3), mesh_s,
                             c.reshape(K, n, 6))
        o = problem.orbit
        rate = o.mean_motion / jax.vmap(anomaly_rate)(
            self.chief.state[collocated_rows(grid)])
        umax = problem.max_acceleration / control_scale(self.problem.energy_problem())
        x0, xf = ocp.params["x0"], ocp.params["xf"]
        return FuelNLP(E=umax * cond.E.reshape(K * n, 6, 3),
                       c=umax * mesh_s.weights.reshape(-1) * rate,
                       d=xf - cond.Phi @ x0 - cond.o, cond=cond, mesh_s=mesh_s, x0=x0,
                       xf=xf, umax=umax, rate=rate)


def transcribe(problem: FuelOptimalTransfer, mesh: SegmentedMesh,
               chief=None) -> Transcription:
    """The problem on `mesh` (breaks as fractions of [s0, s_f]). chief: `transfer_chief`'s
    (s_f, chief at the state rows, chief at the check mesh's rows) of the energy problem on
    tau_mesh(mesh), where the caller has them (the solve's stages share one chief
    integration); None: the rows' chief integrated here."""
    grid = tau_mesh(mesh)
    if chief is None:
        ocp, samples, ok = transfer_ocp(problem.energy_problem(), grid)
        return Transcription(problem, mesh, ocp, grid, samples, ok)
    s_f, rows, check = chief
    ocp, samples, ok = transfer_ocp(problem.energy_problem(), grid, s_f, rows)
    return Transcription(problem, mesh, ocp, grid, samples, ok, s_f, check)


def delta_v_unit(problem: FuelOptimalTransfer):
    """m/s per unit of the condensed cost sum_i c_i |v_i|: control unit / n."""
    return control_scale(problem.energy_problem()) / problem.orbit.mean_motion


def collocated_trajectory(tr: Transcription, nlp: FuelNLP, rows, controls_si, nu, unit,
                          magnitude=0.0) -> Collocated:
    """The `Collocated` trajectory (SI, LVLH) on the transcription's `LGRMesh` or `LGMesh`,
    with the chief's clock: the scaled state rows `rows` (the mesh's `n_rows`, 6;
    `CondensedMesh.mesh_rows`) in LVLH, the controls `controls_si` (K n, 3) in m/s^2
    (`magnitude` > 0: a constant-magnitude engine), and the costates of the final-state
    multiplier nu: dJ/dx (J in units of `unit` per unit of the solver's cost;
    `CondensedMesh.costates`, mapped by the state's scaling)."""
    ocp, chief, energy = tr.ocp, tr.chief, tr.problem.energy_problem()
    rows_s = jnp.concatenate([nlp.mesh_s.state_points[:, :-1].reshape(-1), ocp.sf[None]])
    lam = nlp.cond.costates(nu).reshape(-1, 6)
    costates = unit * jax.vmap(
        lambda p, s: jax.vjp(lambda x: model_state(energy, x, s), jnp.zeros(6))[1](p)[0])(
            lam, nlp.mesh_s.points.reshape(-1))
    states = jax.vmap(lambda x, s: lvlh_state(energy, x, s))(rows, rows_s)
    idx = collocated_rows(tr.grid)
    return Collocated(
        grid=tr.grid, times=chief.t[idx],
        dt_dtau=0.5 * (ocp.sf - ocp.s0) / jax.vmap(anomaly_rate)(chief.state[idx]),
        node_controls=controls_si, node_costates=costates, state_times=chief.t,
        node_states=states, polynomial=states, s0=ocp.s0, sf=ocp.sf, orbit=tr.problem.orbit,
        magnitude=jnp.asarray(magnitude, rows.dtype),
        clock="tabulated" if tr.problem.model == "j2" else "true-anomaly")


def to_solution(tr: Transcription, nlp: FuelNLP, res, valid, extra=None):
    """The `Solution` (SI, LVLH; `Collocated` on the mesh in tau, with the chief's clock)
    of the homotopy's result `res` on the condensed problem `nlp`: the eps-smoothed optimum's
    controls and states, cost = delta-v int |u| dt (m/s), costates dJ/dx (m/s per m and per
    m/s; `collocated_trajectory`), zeros where `valid` is False.

    stats: node_throttle |u| / u_max (K, n), node_primers (the primer at the points), fuel
    (kg), the eps = 1 energy-like solution on the same mesh (energy_node_controls m/s^2,
    energy_dv m/s, energy_fuel kg, energy_cost 1/2 int |u|^2 dt m^2/s^3), eps, multipliers nu
    and energy_multipliers (solver units), partial_throttle (points with 0 < w < 1, where the
    smoothing shows), terminal_error and energy_terminal_error [m, m/s] of the collocated final
    state, homotopy_steps, failed_steps, newton_iterations; the error estimate
    (`energy_optimal.collocation_accuracy` with the bound as its `ThrustLimit`: error_position
    m, error_velocity m/s, relative_error, segment_error, path_violation m/s: the delta-v
    beyond the bound, int max(|u| - u_max, 0) dt between the nodes, which the interpolant
    asks of the engine next to a switch inside a segment); `extra` added as it is."""
    def keep(x):
        return jnp.where(valid, x, jnp.zeros_like(x))

    problem, ocp, grid = tr.problem, tr.ocp, tr.grid
    energy = problem.energy_problem((safety.ThrustLimit(problem.max_acceleration),))
    K, n = tr.mesh.n_segments, tr.mesh.grid.n
    unit = delta_v_unit(problem)

    def outputs(nu, eps):
        v = controls(nu, nlp.E, nlp.c, eps)
        rows = nlp.cond.mesh_rows(nlp.cond.states(nlp.x0, (nlp.umax * v).reshape(K, n, 3)))
        miss = lvlh_state(energy, rows[-1], ocp.sf) - problem.xf
        err = jnp.stack([safe_norm(miss[:3]), safe_norm(miss[3:])])
        # coasting points have v = 0 exactly: the norm's derivative must be 0 there, not NaN
        return v, rows, jnp.sum(nlp.c * safe_norm(v, axis=1)) * unit, err

    v, rows, dv, err = outputs(res.nu, res.eps)
    ve, _, dve, erre = outputs(res.nu_energy, jnp.asarray(1.0, nlp.d.dtype))
    a_si = control_scale(energy)
    U, Ue = nlp.umax * v, nlp.umax * ve
    energy_cost = 0.5 * jnp.sum(nlp.c * jnp.sum(ve**2, axis=1)) * nlp.umax * a_si * unit
    w = safe_norm(v, axis=1)
    trajectory = zero_invalid(valid, collocated_trajectory(tr, nlp, rows, U * a_si, res.nu,
                                                           unit))
    accuracy = collocation_accuracy(energy, grid, rows, U, s_f=tr.s_f, chief=tr.check_chief)
    for name in ("constraint_violation", "violation_position", "violation_velocity"):
        accuracy.pop(name)            # the bound's own measure is path_violation
    return Solution(
        problem=problem, status=res.status, cost=keep(dv),
        duration=problem.duration + 0.0 * dv, trajectory=trajectory,
        stats=dict(node_throttle=keep(w.reshape(K, n)),
                   node_primers=keep(primers(res.nu, nlp.E, nlp.c).reshape(K, n, 3)),
                   fuel=keep(rocket_fuel(dv, problem)),
                   energy_node_controls=keep(Ue * a_si), energy_dv=keep(dve),
                   energy_fuel=keep(rocket_fuel(dve, problem)), energy_cost=keep(energy_cost),
                   eps=res.eps, multipliers=keep(res.nu), energy_multipliers=keep(res.nu_energy),
                   partial_throttle=jnp.sum((w > 1e-9) & (w < 1.0 - 1e-9)),
                   terminal_error=keep(err), energy_terminal_error=keep(erre),
                   homotopy_steps=res.steps, failed_steps=res.failed_steps,
                   newton_iterations=res.newton_iterations,
                   **accuracy, **(extra or {})),
        method="homotopy")
