"""Energy-optimal relative transfer (Mei 2010, eq. 5) on a choice of dynamics model.

minimise  J = 1/2 int_0^T |u|^2 dt      (m^2/s^3)
subject to the relative dynamics of `model`,
           x(0) = x0, x(T) = xf          (LVLH: x radial out, y along-track, z normal; m, m/s)

models: "linear"   linearised about a Keplerian chief (Tschauner-Hempel; the LQ laws' model)
        "two-body" exact nonlinear relative motion, chief and deputy under two-body gravity
        "j2"       exact nonlinear relative motion with J2 acting on both spacecraft; the chief
                   starts on the state that `orbit` gives at its epoch (osculating elements)

The transfer starts at the orbit's epoch (chief true anomaly f0) and lasts `duration` seconds.
Every numeric field is an array leaf (sweeps over e, states or duration reuse one compiled
function); `thrust_axes` is static: which LVLH thrust channels exist (a removed channel can
make the problem uncontrollable, which the laws report as status SINGULAR).

As an NLP (`transfer_ocp`): `EnergyOptimalTransfer` written as an `OptimalControlProblem` in the chief's anomaly.

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

Safety constraints (`constraints`, `jaxlpm.problems.safety`: keep-out ellipsoid, approach cone,
speed limit, thrust bound, passive abort safety; SI, LVLH) become the problem's path
inequalities g <= 0 at the collocation points (`SafetyPath`: the scaled state and control mapped
back to SI, then each constraint's own nondimensional g), solved by the augmented Lagrangian;
the node data then carries the time of every point and the passive-safety drift maps beside
the model's own data. The solution checks every constraint densely between the nodes, in SI
(`safety_stats`).
"""

from dataclasses import dataclass, field, replace

import jax
import jax.numpy as jnp
import numpy as np

from .._validation import Checked, Rule, array_module, coerce_sequences, is_concrete
from ..collocation import Grid
from ..collocation.segments import Mesh
from ..constants import J2_EARTH, R_EARTH
from ..dynamics import (lvlh_frame_motion, relative_lvlh_acceleration,
                        tschauner_hempel_drift)
from ..dynamics.chief import (anomaly_rate, j2_chief, j2_final_anomaly, kepler_chief,
                              kepler_final_anomaly)
from ..dynamics.stm import ya_entries
from ..linalg import materialized, structural_zero
from ..nlp.accuracy import check_flight, check_mesh, collocation_defects, separable_flight
from ..nlp.ocp import OptimalControlProblem
from ..nlp.transcription import (collocated_rows, collocation_s, costates, objective,
                                 state_s, state_tau, support_rows, unpack)
from ..orbits import KeplerOrbit, lvlh_to_th, th_to_lvlh, time_from_true_anomaly
from ..solution import Collocated, Solution
from ..solution.accuracy import accuracy_stats
from . import safety
from .scaling import length_scale

MODELS = ("linear", "two-body", "j2")


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class EnergyOptimalTransfer(Checked):
    """Minimise 1/2 int_0^T |u|^2 dt (m^2/s^3) from x0 to xf in `duration` seconds.

    orbit        the chief's `KeplerOrbit` (SI, rad); the transfer starts at its epoch (t = 0,
                 true anomaly f0)
    x0, xf       the deputy's LVLH state at the start and the end, [x, y, z, vx, vy, vz]
                 (m, m/s; x radial outward, y along-track, z along the orbit normal)
    duration     T (s); `from_revolutions` gives it in chief orbital periods
    thrust_axes  which LVLH thrust channels exist (static; default all three)
    model        "linear" (Tschauner-Hempel), "two-body" or "j2" (static; module docstring)
    j2, r_eq     the J2 coefficient and equatorial radius (m) of the "j2" model
    constraints  safety constraints in SI (LVLH about the target; `jaxlpm.problems.safety`:
                 `KeepOutEllipsoid`, `ApproachCone`, `SpeedLimit`, `ThrustLimit`,
                 `PassiveSafety`), a tuple (default none); with any, the method is
                 "augmented-lagrangian"
    The control u is the thrust acceleration in LVLH axes (m/s^2).
    """

    orbit: KeplerOrbit
    x0: jax.Array
    xf: jax.Array
    duration: jax.Array
    thrust_axes: tuple = field(default=(True, True, True), metadata=dict(static=True))
    model: str = field(default="linear", metadata=dict(static=True))
    j2: jax.Array = J2_EARTH
    r_eq: jax.Array = R_EARTH
    constraints: tuple = field(default=(), metadata=dict(tree=True))

    SHAPES = {"x0": (6,), "xf": (6,), "duration": (), "j2": (), "r_eq": ()}

    def __post_init__(self):
        coerce_sequences(self)
        if isinstance(self.constraints, list):
            object.__setattr__(self, "constraints", tuple(self.constraints))
        axes = self.thrust_axes
        if (isinstance(axes, (tuple, list, np.ndarray)) and np.ndim(axes) == 1
                and all(isinstance(a, (bool, np.bool_)) for a in axes)):
            # static, so compared by jit: Python bools (an array would not compare simply)
            object.__setattr__(self, "thrust_axes", tuple(bool(a) for a in axes))

    @classmethod
    def from_revolutions(cls, orbit, x0, xf, revolutions, thrust_axes=(True, True, True),
                         model="linear", constraints=()):
        """Transfer lasting `revolutions` chief orbital periods (duration = revolutions * 2 pi/n)."""
        if is_concrete(orbit):
            orbit.validate()           # the period needs a > 0 and mu > 0
        return cls(orbit, x0, xf, revolutions * orbit.period, thrust_axes, model,
                   constraints=constraints)

    def replace(self, **kwargs) -> "EnergyOptimalTransfer":
        return replace(self, **kwargs)

    def rules(self):
        """The problem's validity rules, written once (`jaxlpm._validation.Checked`). The
        nonlinear models fly the chief on its orbit, so they need its perigee above the
        surface (r_p = a (1 - e) > r_eq); the linear model is a local expansion that does not
        care."""
        xp = array_module(self)
        o = self.orbit
        rules = [*o.rules(),
                 Rule("x0", xp.all(xp.isfinite(self.x0)), "finite (m, m/s)"),
                 Rule("xf", xp.all(xp.isfinite(self.xf)), "finite (m, m/s)"),
                 Rule("duration", xp.isfinite(self.duration) & (self.duration > 0.0),
                      "a positive, finite duration in s"),
                 Rule("j2", xp.isfinite(self.j2), "finite"),
                 Rule("r_eq", xp.isfinite(self.r_eq) & (self.r_eq > 0.0),
                      "a positive equatorial radius in m")]
        if self.model != "linear":
            rules.append(Rule("orbit", perigee_above_surface(o.a, o.e, self.r_eq),
                              f"an orbit whose perigee a (1 - e) is above r_eq on the "
                              f"{self.model!r} model"))
        return rules + safety.constraint_rules(self.constraints)

    def static_rules(self) -> None:
        """Model and thrust axes, then the fields' shapes (`Checked.static_rules`)."""
        if self.model not in MODELS:
            raise ValueError(f"model must be one of {MODELS}, got {self.model!r}")
        axes = self.thrust_axes
        if len(axes) != 3 or not all(isinstance(a, (bool, np.bool_)) for a in axes):
            raise ValueError(f"thrust_axes must be three booleans (x, y, z), got {axes!r}")
        for c in safety.check_constraints(self.constraints):
            c.static_rules()
        super().static_rules()

    def harmless(self) -> "EnergyOptimalTransfer":
        """A valid transfer of the same model and thrust axes (1 m radial offset to the
        origin in 1000 s about a circular orbit), for invalid members of a batch."""
        return self.replace(orbit=self.orbit.harmless(), x0=jnp.array([1.0, 0, 0, 0, 0, 0]),
                            xf=jnp.zeros(6), duration=1000.0, j2=0.0, r_eq=R_EARTH,
                            constraints=tuple(c.harmless() for c in self.constraints))


def perigee_above_surface(a, e, r_eq=R_EARTH):
    """True where the chief's perigee radius a (1 - e) exceeds the body's radius r_eq (m)."""
    return a * (1.0 - e) > r_eq


def check_problem(problem: EnergyOptimalTransfer) -> None:
    """Validate at the Python boundary: everything when the inputs are concrete, the static
    part (types, shapes, model) when they are traced."""
    if not isinstance(problem, EnergyOptimalTransfer):
        raise ValueError(f"problem must be an EnergyOptimalTransfer, got "
                         f"{type(problem).__name__}")
    problem.check()


def th_dynamics(s, x, u, data, p):
    """d/ds of the linear model's scaled Tschauner-Hempel state at true anomaly s, control u
    in units of L k^4 (m/s^2; k^2 = sqrt(mu / p^3), Mei 2010 eq. 1, 11)."""
    return tschauner_hempel_drift(s, x, p["e"]) + jnp.concatenate(
        [jnp.zeros(3), p["axes"] * u / (1.0 + p["e"] * jnp.cos(s)) ** 3])


def _th_cost(s, x, u, data, p):
    return 0.5 * jnp.dot(u, u) / (1.0 + p["e"] * jnp.cos(s)) ** 2


def lvlh_dynamics(s, x, u, data, p):
    """d/ds of the scaled LVLH state [r / L, v / (L n)] on the two-body or J2 model, control u
    in units of L n^2; data = (chief position (m), `lvlh_frame_motion`, n dt/ds)."""
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


def chief_at(problem: EnergyOptimalTransfer, s_f, *taus):
    """([ChiefSamples at each tau, arrays in [-1, 1] of [f0, s_f]], ok): analytic on the
    Keplerian models; on "j2" one integration saves at all of them, sorted together (the
    saved states are interpolated within the adaptive steps: each set's samples equal those
    of an integration of its own to the integrator's round-off)."""
    o = problem.orbit
    if problem.model != "j2":
        return ([kepler_chief(o, o.f0 + 0.5 * (s_f - o.f0) * (tau + 1.0)) for tau in taus],
                jnp.array(True))
    every = jnp.concatenate(taus)
    order = jnp.argsort(every)
    samples, ok = j2_chief(o, s_f, 0.5 * (every[order] + 1.0), problem.j2, problem.r_eq)
    samples = jax.tree_util.tree_map(lambda x: x[jnp.argsort(order)], samples)
    ends = np.cumsum([tau.shape[0] for tau in taus])
    return [jax.tree_util.tree_map(lambda x: x[a:b], samples)
            for a, b in zip([0, *ends[:-1]], ends)], ok


def transfer_chief(problem: EnergyOptimalTransfer, grid):
    """(s_f, (chief at the grid's state rows, ok), (chief at its check mesh's state rows,
    ok)): the final anomaly and the chief for `transfer_ocp` and `collocation_accuracy`, the
    two sample sets by one integration on the J2 model (`chief_at`)."""
    s_f, ok_f = final_anomaly(problem)
    (rows, check), ok = chief_at(problem, s_f, state_tau(grid), state_tau(check_mesh(grid)))
    return s_f, (rows, ok & ok_f), (check, ok & ok_f)


def model_state(problem: EnergyOptimalTransfer, x_lvlh, s):
    """LVLH state (m, m/s) at anomaly s -> the solver's scaled state."""
    o = problem.orbit
    return scaled_state(problem.model, x_lvlh, s, o.e, o.k2, o.mean_motion,
                        length_scale(problem))


def scaled_state(model, x_lvlh, s, e, k2, n, length):
    """`model_state` in numbers: the Tschauner-Hempel state over `length` on the linear
    model, [r / length, v / (length n)] on the others."""
    if model == "linear":
        return lvlh_to_th(x_lvlh, s, e, k2) / length
    return x_lvlh / jnp.concatenate([jnp.full(3, length), jnp.full(3, length * n)])


def _unscaled_state(model, x, s, e, k2, n, length):
    """The solver's state x at anomaly s -> LVLH (m, m/s); `lvlh_state` in numbers."""
    if model == "linear":
        return th_to_lvlh(x * length, s, e, k2)
    return x * jnp.concatenate([jnp.full(3, length), jnp.full(3, length * n)])


def _control_unit(model, k2, n, length):
    """u (m/s^2) per unit of the solver's control; `control_scale` in numbers."""
    return length * (k2**2 if model == "linear" else n**2)


def lvlh_state(problem: EnergyOptimalTransfer, x, s):
    """Inverse of `model_state`."""
    o = problem.orbit
    return _unscaled_state(problem.model, x, s, o.e, o.k2, o.mean_motion,
                           length_scale(problem))


def control_scale(problem: EnergyOptimalTransfer):
    """u (m/s^2) = control_scale * the solver's control."""
    o = problem.orbit
    return _control_unit(problem.model, o.k2, o.mean_motion, length_scale(problem))


def cost_scale(problem: EnergyOptimalTransfer):
    """1/2 int |u|^2 dt (m^2/s^3) = cost_scale * the solver's cost."""
    o, L = problem.orbit, length_scale(problem)
    return L**2 * (o.k2**3 if problem.model == "linear" else o.mean_motion**3)


def transfer_ocp(problem: EnergyOptimalTransfer, grid, s_f=None, chief=None):
    """The transfer as an `OptimalControlProblem` on `grid`, with the chief sampled at the
    state rows (`ChiefSamples`, for times and the LVLH map) and an integration flag ok.
    s_f: the final anomaly where the caller has it (`final_anomaly`: a J2 chief integration
    less in the program), None: computed here; chief: (the samples at the grid's state
    rows, ok) where the caller has them (`transfer_chief`), None: integrated here."""
    o = problem.orbit
    s_f, ok_f = final_anomaly(problem) if s_f is None else (s_f, jnp.array(True))
    if chief is None:
        (chief,), ok_c = chief_at(problem, s_f, state_tau(grid))
    else:
        chief, ok_c = chief
    x0 = model_state(problem, problem.x0, o.f0)
    xf = model_state(problem, problem.xf, s_f)
    axes = jnp.asarray(problem.thrust_axes, x0.dtype)
    params = {"x0": x0, "xf": xf, "e": o.e, "axes": axes}
    if problem.model == "linear":
        dynamics, cost, data = th_dynamics, _th_cost, None
    else:
        states = chief.state[collocated_rows(grid)]
        q = o.mean_motion / jax.vmap(anomaly_rate)(states)
        # two-body: no J2 terms in the program at all (`gravity`: j2 = None)
        j2 = problem.j2 if problem.model == "j2" else None
        frames = jax.vmap(lvlh_frame_motion, in_axes=(0, None, None, None))(
            states, o.mu, j2, problem.r_eq)
        data = (states[:, :3], frames, q)
        params.update(length=length_scale(problem), n=o.mean_motion, mu=o.mu, j2=j2,
                      r_eq=problem.r_eq)
        dynamics, cost = lvlh_dynamics, _lvlh_cost
    ocp = OptimalControlProblem(
        n_x=6, n_u=3, dynamics=dynamics, running_cost=cost, boundary=_fixed_ends,
        s0=o.f0 + 0.0 * s_f, sf=s_f, params=params, node_data=data)
    if problem.constraints:
        ocp = _with_safety(problem, ocp, chief.t[collocated_rows(grid)])
    return ocp, chief, ok_f & ok_c


@dataclass(frozen=True)
class OnModelData:
    """A model's dynamics or running cost on node data (model data, safety data): hashable,
    so that equal wrappers key one compiled solver."""

    fn: object

    def __call__(self, s, x, u, data, p):
        return self.fn(s, x, u, data[0], p)


@dataclass(frozen=True)
class SafetyPath:
    """The path inequalities g(s, x, u, data, p) <= 0 of the problem's safety constraints
    (`jaxlpm.problems.safety.path_values`) on the solver's state and control of `model`."""

    model: str

    def __call__(self, s, x, u, data, p):
        x_si = _unscaled_state(self.model, x, s, p["e"], p["k2"], p["n"], p["length"])
        u_si = p["axes"] * u * _control_unit(self.model, p["k2"], p["n"], p["length"])
        point = data[1]
        return safety.path_values(p["constraints"], x_si, u_si, point["t"], point["pad"],
                                  point["drift"], p["length"])


def _with_safety(problem: EnergyOptimalTransfer, ocp, t):
    """`ocp` with the problem's safety constraints as path inequalities (`SafetyPath`); t:
    the times of its collocation points (s since the start)."""
    o = problem.orbit
    params = {**ocp.params, "constraints": problem.constraints, "k2": o.k2,
              "n": o.mean_motion, "length": length_scale(problem)}
    data = (ocp.node_data, {"t": t, "pad": safety.node_pad(t),
                            "drift": safety.node_drift(problem.constraints, o, t)})
    return ocp.replace(dynamics=OnModelData(ocp.dynamics),
                       running_cost=OnModelData(ocp.running_cost),
                       path=SafetyPath(problem.model), params=params, node_data=data)


def scaled_rows(solution):
    """(state rows, controls) of a Newton-KKT `Solution` in the solver's units (the inverse of
    `to_solution`'s unscaling: `model_state` of its LVLH rows, controls / `control_scale`)."""
    problem = solution.problem
    X = jax.vmap(lambda x, s: model_state(problem, x, s))(solution.node_states,
                                                          solution.stats["state_s"])
    return X, solution.node_controls / control_scale(problem)


def collocation_accuracy(problem: EnergyOptimalTransfer, grid, X, U, control_map=None,
                         s_f=None, chief=None):
    """`jaxlpm.solution.accuracy` stats (SI, LVLH) of the solution with scaled state rows X
    and controls U on `grid` (the units of `transfer_ocp`): the GPOPS-II estimate on the
    check mesh, whose chief is sampled at the check points, the errors mapped to LVLH
    (`lvlh_state` is linear in the state at a given anomaly). control_map: applied to the
    interpolated control before it is flown (a constant-magnitude engine's direction). s_f:
    the final anomaly, chief: the chief at the check mesh's rows with its flag, where the
    caller has them (`transfer_ocp`, `transfer_chief`)."""
    check = check_mesh(grid)
    # the defects and the flight need the model alone: the constraints are checked in SI by
    # `safety_stats`, with their own (denser) drift samples
    ocp_check, chief_check, _ = transfer_ocp(problem.replace(constraints=()), check, s_f,
                                             chief)
    d = collocation_defects(ocp_check, check, grid, X, U, control_map=control_map)
    # the linear model's flight by its transition matrix on a fixed grid without path
    # constraints (the LQ laws', Newton's: smooth controls); meshes and constrained solutions
    # keep the Newton flight the refinement was validated with (with the new one,
    # tests/test_safety.py's speed-limit approach refined a rung further: docs/accuracy.md)
    if problem.model == "linear" and isinstance(grid, Grid) and not problem.constraints:
        flown = separable_flight(ocp_check, check, grid, X, U, ya_kernel(problem.orbit),
                                 control_map=control_map)
    else:
        flown = check_flight(ocp_check, check, grid, X, U, control_map=control_map)
    to_si = jax.vmap(jax.vmap(lambda x, s: lvlh_state(problem, x, s)))
    stats = accuracy_stats(to_si(flown - d.states, d.s), d.relative)
    if problem.constraints:
        stats.update(safety_stats(problem, grid, X, U, state_tau(check),
                                  state_s(ocp_check, check), chief_check.t))
    return stats


def ya_kernel(orbit: KeplerOrbit):
    """The linear model's transition matrix as `separable_flight`'s kernel: Yamanaka &
    Ankersen's Phi(f, r) = (F0(f) + (J_f - J_r) F1(f)) F^-1(r) (2002, eq. 82-86; J = k2 t, t the
    time since the origin, `time_from_true_anomaly`) is P_1 Q_1 + P_2 Q_2 with
    P = (F0 + J_f F1, F1) and Q = (F^-1, -J_r F^-1), on the Tschauner-Hempel state
    [x~, y~, z~, x~', y~', z~'] (the linear model's, in any unit of length), as nested lists
    of arrays shaped like f (`ya_entries`)."""
    def kernel(f, origin):
        t = time_from_true_anomaly(orbit, f) - time_from_true_anomaly(orbit, origin)
        sf, cf, J = materialized(jnp.sin(f), jnp.cos(f), orbit.k2 * t)
        F0, F1, Finv = ya_entries(sf, cf, orbit.e)
        P1 = [[a if structural_zero(b) else a + J * b for a, b in zip(*rows)]
              for rows in zip(F0, F1)]
        Q2 = [[x if structural_zero(x) else -J * x for x in row] for row in Finv]
        return [P1, F1], [Finv, Q2]
    return kernel


def safety_stats(problem: EnergyOptimalTransfer, grid, X, U, tau, s, t):
    """The safety constraints checked densely between the nodes, in SI: the state polynomial
    and control interpolant of the solution (scaled state rows X, controls U on `grid`) at
    the points tau (grid coordinate; anomalies s, times t: the check mesh's state rows), the
    passive-safety drift sampled `safety.CHECK_DRIFT_FACTOR` times as densely as the solver
    samples it.

    constraint_violation  (n_c,) each constraint's largest violation (its unit: m, m/s or
                          m/s^2; 0 where it holds everywhere)
    violation_position    the largest of those in m (keep-out, cone, passive safety)
    violation_velocity    the largest in m/s (speed limits)
    path_violation        the delta-v beyond the thrust limits, int max(|u| - u_max, 0) dt
                          (m/s, the trapezoidal rule on the points; the fuel-optimal
                          family's measure)
    segment_violation     (K, 3) the same three per segment of the grid (position m,
                          velocity m/s, delta-v beyond the bound m/s; K = 1 for a `Grid`):
                          where mesh refinement splits for the constraints
                          (`jaxlpm.solution.accuracy.refinement_error`)
    """
    cons = problem.constraints
    Xc = jax.vmap(lambda tk: grid.interpolate_state(X[support_rows(grid)], tk))(tau)
    Uc = jax.vmap(lambda tk: grid.interpolate_control(U, tk))(tau)
    x_si = jax.vmap(lambda x, sk: lvlh_state(problem, x, sk))(Xc, s)
    u_si = Uc * jnp.asarray(problem.thrust_axes, X.dtype) * control_scale(problem)
    drift = safety.node_drift(cons, problem.orbit, t, safety.CHECK_DRIFT_FACTOR)
    v = jax.vmap(safety.violations, in_axes=(None, 0, 0, 0, 0))(cons, x_si, u_si, t, drift)
    worst = jnp.maximum(jnp.max(v, axis=0), 0.0)

    k = grid.n_segments if isinstance(grid, Mesh) else 1
    excess = jnp.maximum(v, 0.0)
    # the rows of the check mesh's segment-major pieces, the last (the final state) counted
    # with the last segment; the trapezoid between rows j and j + 1 belongs to row j's segment
    per_segment = jnp.max(excess[:-1].reshape(k, -1, excess.shape[1]), axis=1)
    per_segment = per_segment.at[-1].max(excess[-1])
    trapezoids = (0.5 * jnp.diff(t)[:, None] * (excess[1:] + excess[:-1])).reshape(
        k, -1, excess.shape[1]).sum(axis=1)

    def largest(kinds, values):
        picked = [values[..., i] for i, c in enumerate(cons) if isinstance(c, kinds)]
        return (jnp.max(jnp.stack(picked), axis=0) if picked
                else jnp.zeros(values.shape[:-1], X.dtype))

    position = (safety.KeepOutEllipsoid, safety.ApproachCone, safety.PassiveSafety)
    return dict(constraint_violation=worst,
                violation_position=largest(position, worst),
                violation_velocity=largest(safety.SpeedLimit, worst),
                path_violation=largest(safety.ThrustLimit, jnp.sum(trapezoids, axis=0)),
                segment_violation=jnp.stack([largest(position, per_segment),
                                             largest(safety.SpeedLimit, per_segment),
                                             largest(safety.ThrustLimit, trapezoids)], axis=1))


def to_solution(problem: EnergyOptimalTransfer, ocp, grid, chief, result, status, valid,
                method="newton", extra=None, cost_unit=None, check_chief=None):
    """The `Solution` (SI, LVLH) of the transcribed transfer solved to `result` (an
    `NLPResult` of `transfer_ocp(problem, grid)`, whose chief samples are `chief`): states
    and controls unscaled, the cost 1/2 int |u|^2 dt, costates dJ/dx = cost_unit
    (dx~/dx)^T dJ~/dx~ (x~ = `model_state`(x)), zeros where `valid` is False. cost_unit: the
    SI cost per unit of the solver's objective (default `cost_scale`; another running cost,
    such as the smoothed delta-v of `jaxlpm.solvers.fuel_constrained`, gives its own).
    check_chief: the chief at the check mesh's rows and its flag (`transfer_chief`), or None
    (integrated for the estimate).

    stats: node_s, state_s (anomalies of the collocation points and state rows, rad),
    cost_true_anomaly (k^2 cost, m^2/s^4), costates_scaled (dJ~/dx~), multipliers,
    constraint_residual, stationarity_residual (scaled units), iterations, history; `extra`
    (a dict) is added to them as it is (the augmented Lagrangian's own numbers)."""
    def keep(x):
        return jnp.where(valid, x, jnp.zeros_like(x))

    X, U, _ = unpack(result.z, ocp, grid)
    rows_s = state_s(ocp, grid)
    node_s = collocation_s(ocp, grid)
    states = keep(jax.vmap(lambda x, s: lvlh_state(problem, x, s))(X, rows_s))
    cost_unit = cost_scale(problem) if cost_unit is None else cost_unit
    cost = cost_unit * objective(result.z, ocp, grid)
    lam = costates(result.z, result.multipliers, ocp, grid)
    node_costates = cost_unit * jax.vmap(
        lambda p, s: jax.vjp(lambda x: model_state(problem, x, s), jnp.zeros(6))[1](p)[0])(
            lam, node_s)
    rows = collocated_rows(grid)
    trajectory = Collocated(
        grid=grid, times=chief.t[rows],
        dt_dtau=0.5 * (ocp.sf - ocp.s0) / jax.vmap(anomaly_rate)(chief.state[rows]),
        node_controls=keep(U * control_scale(problem)), node_costates=keep(node_costates),
        state_times=chief.t, node_states=states, polynomial=states, s0=ocp.s0, sf=ocp.sf,
        orbit=problem.orbit, clock="tabulated" if problem.model == "j2" else "true-anomaly")
    return Solution(
        problem=problem, status=status, cost=keep(cost),
        duration=problem.duration + 0.0 * cost, trajectory=trajectory,
        stats=dict(node_s=node_s, state_s=rows_s,
                   cost_true_anomaly=keep(problem.orbit.k2 * cost),
                   costates_scaled=keep(lam), multipliers=keep(result.multipliers),
                   constraint_residual=keep(result.constraint_residual),
                   stationarity_residual=keep(result.stationarity_residual),
                   iterations=result.iterations, history=keep(result.history),
                   **collocation_accuracy(problem, grid, X, U, s_f=ocp.sf,
                                          chief=check_chief),
                   **(extra or {})),
        method=method)
