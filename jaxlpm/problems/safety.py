"""Rendezvous safety constraints, declared in SI on a transfer problem (`constraints=[...]`).

Every constraint lives in the chief's LVLH frame about the target (x radial outward, y
along-track, z along the orbit normal; m, m/s, m/s^2, s since the start of the transfer). Each
gives the solver path values g <= 0 at the collocation points (nondimensional, O(1) near their
boundary: the augmented Lagrangian's `OptimalControlProblem.path`) and reports its violation in
SI at any point of the solution (`violation`: positive where violated), which the solution
checks densely between the nodes (`jaxlpm.problems.energy_optimal.safety_stats`).

  KeepOutEllipsoid  sum_i ((r_i - c_i) / a_i)^2 >= 1 over a time window;
                    violation: the depth inside along the ray from the centre (m)
  ApproachCone      inside the range R of the port p: the line of sight d = r - p within the
                    half-angle alpha of the axis a (cos alpha |d| <= a.d); violation: the
                    distance from d to the cone (m)
  SpeedLimit        |v| <= v0 + k |r - c| (Fehse 2003, "Automated rendezvous and docking of
                    spacecraft", §5.6: approach velocity decreasing with range);
                    violation: |v| - (v0 + k |r - c|) (m/s)
  ThrustLimit       |u| <= u_max; violation: |u| - u_max (m/s^2)
  PassiveSafety     the free drift from the state at every point, for `horizon` seconds on the
                    linear model of the problem's Keplerian chief (Yamanaka & Ankersen 2002,
                    `yamanaka_ankersen_stm`), stays outside a keep-out ellipsoid (Breger & How
                    2008, "Safe trajectories for autonomous rendezvous of spacecraft", JGCD
                    31(5)); sampled at `samples` drift times for the solver and at
                    `CHECK_DRIFT_FACTOR` times as many for the check; violation: the largest
                    depth of the drift inside the ellipsoid (m)

Every constraint but the thrust limit may be active over a window [t_start, t_end] of the
transfer (s since its start; default: all of it): a docking approach enters the keep-out zone in
its last phase, inside the approach cone. The solver enforces a windowed constraint at every
point within one point spacing of the window (`node_pad`), the dense check only inside it. Every number is an array leaf (sweepable,
differentiable: the solution's implicit gradients reach them); `samples` is static.
"""

from dataclasses import dataclass, field, replace

import jax
import jax.numpy as jnp
import numpy as np

from .._validation import Checked, Rule, array_module, coerce_sequences
from ..dynamics.stm import yamanaka_ankersen_stm
from ..orbits import lvlh_to_th, th_to_lvlh
from ..orbits.kepler import true_anomaly_from_time

ALWAYS = (-np.inf, np.inf)       # the default window: the whole transfer
CHECK_DRIFT_FACTOR = 4           # drift samples of the dense check per sample of the solver
_NORM_FLOOR = 1e-9               # |d| is smoothed as sqrt(|d|^2 + (floor scale)^2): a
#                                  constraint may end on its apex (the docking port)
_CONE_SMOOTHING = 1e-6           # the approach cone's smoothing of |d|, per unit range


def _window_rules(obj):
    xp = array_module(obj)
    w = obj.window
    return Rule("window", ~xp.any(xp.isnan(w)) & (w[0] <= w[1]),
                "[t_start, t_end] with t_start <= t_end (s since the start; inf allowed)")


def _active(window, t, pad=0.0):
    """Whether [t - pad, t + pad] meets the window (pad 0: t in it)."""
    return (t + pad >= window[0]) & (t - pad <= window[1])


def node_pad(t):
    """(n,) the larger gap from each point to its neighbours (s), for times t (n,) in
    increasing order: a constraint whose window meets [t - pad, t + pad] holds at the point,
    so the points on both sides of a window's edge enforce it and the path between them,
    which the window covers in part, is held like any other interval between points (the
    excess shrinks with the mesh)."""
    gaps = jnp.diff(t)
    return jnp.maximum(jnp.concatenate([gaps[:1], gaps]), jnp.concatenate([gaps, gaps[-1:]]))


def _ellipsoid_q2(r, centre, semi_axes):
    """sum ((r - c) / a)^2: 1 on the ellipsoid's surface."""
    return jnp.sum(((r - centre) / semi_axes) ** 2)


def _ellipsoid_depth(r, centre, semi_axes):
    """How deep r lies inside the ellipsoid, along the ray from its centre (m; negative
    outside): |d| (1/q - 1), q = sqrt(`_ellipsoid_q2`); the exact depth for a sphere."""
    d = r - centre
    q = jnp.sqrt(_ellipsoid_q2(r, centre, semi_axes))
    ray = jnp.linalg.norm(d) / jnp.where(q > 0.0, q, 1.0)     # |d| / q: centre-to-surface
    ray = jnp.where(q > 0.0, ray, jnp.min(semi_axes))
    return ray * (1.0 - q)


class _Constraint(Checked):
    """What every safety constraint has: `values` (the solver's g) and `violation` (SI);
    `PassiveSafety` also has `drift_maps` (its per-point data, `node_drift`)."""

    UNIT = "m"

    def replace(self, **kwargs):
        return replace(self, **kwargs)

    def __post_init__(self):
        coerce_sequences(self)


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class KeepOutEllipsoid(_Constraint):
    """Stay outside the ellipsoid sum_i ((r_i - centre_i) / semi_axes_i)^2 = 1 (LVLH, m)
    while t (s since the start) is in `window`. A sphere: three equal semi-axes."""

    semi_axes: jax.Array
    centre: jax.Array = (0.0, 0.0, 0.0)
    window: jax.Array = ALWAYS

    SHAPES = {"semi_axes": (3,), "centre": (3,), "window": (2,)}

    def rules(self):
        xp = array_module(self)
        return [Rule("semi_axes", xp.all(xp.isfinite(self.semi_axes) & (self.semi_axes > 0)),
                     "three positive, finite semi-axes (m)"),
                Rule("centre", xp.all(xp.isfinite(self.centre)), "finite (m)"),
                _window_rules(self)]

    def harmless(self):
        return KeepOutEllipsoid(jnp.ones(3), jnp.zeros(3), jnp.array([-2.0, -1.0]))

    def values(self, x, u, t, pad, drift, length):
        g = 1.0 - _ellipsoid_q2(x[:3], self.centre, self.semi_axes)
        return jnp.where(_active(self.window, t, pad), g, -1.0)[None]

    def violation(self, x, u, t, drift):
        depth = _ellipsoid_depth(x[:3], self.centre, self.semi_axes)
        return jnp.where(_active(self.window, t), depth, -jnp.inf)


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class ApproachCone(_Constraint):
    """Inside `range` (m) of the docking port `port` (LVLH, m), while t is in `window`, keep
    the line of sight d = r - port within `half_angle` (rad, < pi/2) of `axis` (LVLH, any
    length: the direction from the port out along the approach corridor)."""

    axis: jax.Array
    half_angle: jax.Array
    range: jax.Array
    port: jax.Array = (0.0, 0.0, 0.0)
    window: jax.Array = ALWAYS

    SHAPES = {"axis": (3,), "half_angle": (), "range": (), "port": (3,), "window": (2,)}

    def rules(self):
        xp = array_module(self)
        return [Rule("axis", xp.all(xp.isfinite(self.axis))
                     & (xp.linalg.norm(self.axis) > 0.0), "a finite, nonzero direction"),
                Rule("half_angle", (self.half_angle > 0.0) & (self.half_angle < 0.5 * xp.pi),
                     "in (0, pi/2) rad"),
                Rule("range", xp.isfinite(self.range) & (self.range > 0.0),
                     "a positive, finite range (m)"),
                Rule("port", xp.all(xp.isfinite(self.port)), "finite (m)"),
                _window_rules(self)]

    def harmless(self):
        return ApproachCone(jnp.array([0.0, -1.0, 0.0]), jnp.asarray(0.5), jnp.asarray(1.0),
                            jnp.zeros(3), jnp.array([-2.0, -1.0]))

    def values(self, x, u, t, pad, drift, length):
        """min((R + |v| pad - |d|) / R, (cos alpha |d| - a.d) / R) <= 0: out of reach of the
        range, or inside the half-cone (the second-order cone cos alpha |d| <= a.d, convex
        and of degree one in d, so its margin shrinks only linearly towards the port). The
        range is padded by the distance |v| pad the chaser covers in `node_pad`'s gap, as
        the windows are: the points on both sides of the range's edge are held in the cone,
        so the path between them cannot cut the corner where the sphere of radius R meets
        the cone (a union of two sets: without the pad the solver enters the range between
        two points, outside the cone, wherever the mesh is coarsest; measured on
        `jaxlpm.cases.approach`, 0.15-2.1 m outside at every rung up to 64 x 8 points as the
        crossing moved from segment to segment). The pad shrinks with the mesh. |d| is
        smoothed to sqrt(|d|^2 + eps^2) - eps, eps = 1e-6 R (it ends on the port with g = 0
        and a finite slope; the smoothing moves the boundary by at most 1e-6 R), and |v| pad
        to sqrt(|v|^2 pad^2 + eps^2)."""
        a = self.axis / jnp.linalg.norm(self.axis)
        d = x[:3] - self.port
        eps = _CONE_SMOOTHING * self.range
        rho = jnp.sqrt(jnp.dot(d, d) + eps ** 2) - eps
        reach = self.range + jnp.sqrt(jnp.dot(x[3:], x[3:]) * pad ** 2 + eps ** 2)
        g = jnp.minimum(reach - rho, jnp.cos(self.half_angle) * rho - jnp.dot(a, d))
        return jnp.where(_active(self.window, t, pad), g / self.range, -1.0)[None]

    def violation(self, x, u, t, drift):
        """|d| sin(theta - alpha), theta the angle of d from the axis (the distance to the
        cone; |d| beyond 90 degrees), inside the range; -inf outside it."""
        a = self.axis / jnp.linalg.norm(self.axis)
        d = x[:3] - self.port
        rho = jnp.linalg.norm(d)
        theta = jnp.arctan2(jnp.linalg.norm(jnp.cross(a, d)), jnp.dot(a, d))
        dist = rho * jnp.sin(jnp.clip(theta - self.half_angle, -0.5 * jnp.pi, 0.5 * jnp.pi))
        return jnp.where(_active(self.window, t) & (rho <= self.range), dist, -jnp.inf)


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class SpeedLimit(_Constraint):
    """|v| <= v0 + k |r - centre| (m/s; v0 in m/s, k in 1/s, centre LVLH m) while t is in
    `window`: the approach slows down as the range closes."""

    v0: jax.Array
    k: jax.Array = 0.0
    centre: jax.Array = (0.0, 0.0, 0.0)
    window: jax.Array = ALWAYS

    UNIT = "m/s"
    SHAPES = {"v0": (), "k": (), "centre": (3,), "window": (2,)}

    def rules(self):
        xp = array_module(self)
        return [Rule("v0", xp.isfinite(self.v0) & (self.v0 >= 0.0), "finite and >= 0 (m/s)"),
                Rule("k", xp.isfinite(self.k) & (self.k >= 0.0)
                     & ((self.v0 > 0.0) | (self.k > 0.0)),
                     "finite and >= 0 (1/s), with v0 + k > 0"),
                Rule("centre", xp.all(xp.isfinite(self.centre)), "finite (m)"),
                _window_rules(self)]

    def harmless(self):
        return SpeedLimit(jnp.asarray(1.0), jnp.asarray(0.0), jnp.zeros(3),
                          jnp.array([-2.0, -1.0]))

    def _bound(self, r, length):
        d = r - self.centre
        return self.v0 + self.k * jnp.sqrt(jnp.dot(d, d) + (_NORM_FLOOR * length) ** 2)

    def values(self, x, u, t, pad, drift, length):
        """(|v|^2 - (v0 + k |d|)^2) / (v0 + k L)^2, L the problem's length scale."""
        bound = self._bound(x[:3], length)
        g = (jnp.dot(x[3:], x[3:]) - bound ** 2) / (self.v0 + self.k * length) ** 2
        return jnp.where(_active(self.window, t, pad), g, -1.0)[None]

    def violation(self, x, u, t, drift):
        excess = jnp.linalg.norm(x[3:]) - self.v0 - self.k * jnp.linalg.norm(x[:3] - self.centre)
        return jnp.where(_active(self.window, t), excess, -jnp.inf)


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class ThrustLimit(_Constraint):
    """|u| <= u_max (m/s^2) over the whole transfer (for energy-optimal transfers; the
    fuel-optimal and minimum-time families have their own thrust)."""

    u_max: jax.Array

    UNIT = "m/s^2"
    SHAPES = {"u_max": ()}

    def rules(self):
        xp = array_module(self)
        return [Rule("u_max", xp.isfinite(self.u_max) & (self.u_max > 0.0),
                     "a positive, finite acceleration (m/s^2)")]

    def harmless(self):
        return ThrustLimit(jnp.asarray(1.0))

    def values(self, x, u, t, pad, drift, length):
        return ((jnp.dot(u, u) - self.u_max ** 2) / self.u_max ** 2)[None]

    def violation(self, x, u, t, drift):
        return jnp.linalg.norm(u) - self.u_max


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class PassiveSafety(_Constraint):
    """From the state at every point with t in `window`, the free drift (no thrust, the
    linear model of the problem's Keplerian chief) over the next `horizon` seconds stays
    outside the ellipsoid of `semi_axes` about `centre` (LVLH, m): an abort at any moment is
    safe. The solver samples the drift at `samples` (static) evenly spaced times after the
    point; the dense check at `CHECK_DRIFT_FACTOR` times as many."""

    semi_axes: jax.Array
    horizon: jax.Array
    centre: jax.Array = (0.0, 0.0, 0.0)
    window: jax.Array = ALWAYS
    samples: int = field(default=48, metadata=dict(static=True))

    SHAPES = {"semi_axes": (3,), "horizon": (), "centre": (3,), "window": (2,)}

    def rules(self):
        xp = array_module(self)
        return [Rule("semi_axes", xp.all(xp.isfinite(self.semi_axes) & (self.semi_axes > 0)),
                     "three positive, finite semi-axes (m)"),
                Rule("horizon", xp.isfinite(self.horizon) & (self.horizon > 0.0),
                     "a positive, finite drift duration (s)"),
                Rule("centre", xp.all(xp.isfinite(self.centre)), "finite (m)"),
                _window_rules(self)]

    def static_rules(self) -> None:
        if isinstance(self.samples, bool) or not isinstance(self.samples, (int, np.integer)) \
                or self.samples < 2:
            raise ValueError(f"samples must be an integer >= 2 (drift times per horizon), got "
                             f"{self.samples!r}")
        super().static_rules()

    def harmless(self):
        return PassiveSafety(jnp.ones(3), jnp.asarray(1.0), jnp.zeros(3),
                             jnp.array([-2.0, -1.0]), self.samples)

    def drift_maps(self, orbit, t, factor: int = 1):
        """(M, 3, 6): the LVLH position after each of M = factor x samples drift times
        horizon j / M (j = 1 .. M) from the LVLH state at time t (s), a linear map (YA STM
        of the Tschauner-Hempel state between the Keplerian anomalies at t and t + tau)."""
        m = factor * self.samples
        taus = self.horizon * jnp.arange(1, m + 1) / m
        f0 = true_anomaly_from_time(orbit, t)

        def one(tau):
            f = true_anomaly_from_time(orbit, t + tau)
            phi = yamanaka_ankersen_stm(f, f0, tau, orbit.e, orbit.k2)
            return jax.jacfwd(lambda x: th_to_lvlh(
                phi @ lvlh_to_th(x, f0, orbit.e, orbit.k2), f, orbit.e, orbit.k2)[:3])(
                    jnp.zeros(6, taus.dtype))

        return jax.vmap(one)(taus)

    def values(self, x, u, t, pad, drift, length):
        q2 = jax.vmap(lambda P: _ellipsoid_q2(P @ x, self.centre, self.semi_axes))(drift)
        return jnp.where(_active(self.window, t, pad), 1.0 - q2, -1.0)

    def violation(self, x, u, t, drift):
        depth = jax.vmap(lambda P: _ellipsoid_depth(P @ x, self.centre, self.semi_axes))(drift)
        return jnp.where(_active(self.window, t), jnp.max(depth), -jnp.inf)


CONSTRAINTS = (KeepOutEllipsoid, ApproachCone, SpeedLimit, ThrustLimit, PassiveSafety)


def check_constraints(constraints) -> tuple:
    """The constraints as a tuple (static checks: types, shapes); ValueError for anything
    that is not one of `CONSTRAINTS`."""
    if not isinstance(constraints, (tuple, list)):
        raise ValueError(f"constraints must be a list or tuple of safety constraints "
                         f"({', '.join(c.__name__ for c in CONSTRAINTS)}), got "
                         f"{constraints!r:.80}")
    for i, c in enumerate(constraints):
        if not isinstance(c, CONSTRAINTS):
            raise ValueError(f"constraints[{i}] must be one of "
                             f"{', '.join(k.__name__ for k in CONSTRAINTS)}, got "
                             f"{type(c).__name__}")
    return tuple(constraints)


def constraint_rules(constraints) -> list:
    """Every constraint's `Rule`s, named constraints[i].field."""
    return [Rule(f"constraints[{i}].{r.name}", r.ok, r.allowed)
            for i, c in enumerate(constraints) for r in c.rules()]


def node_drift(constraints, orbit, t, factor: int = 1) -> tuple:
    """Per constraint, its drift maps at the times t (n,) (`PassiveSafety.drift_maps`:
    (n, M, 3, 6)), None for the others: the per-point data `path_values` and `violations`
    take."""
    return tuple(jax.vmap(lambda tk: c.drift_maps(orbit, tk, factor))(t)
                 if isinstance(c, PassiveSafety) else None for c in constraints)


def path_values(constraints, x, u, t, pad, drift, length):
    """(n_g,) the solver's g of every constraint at one point (LVLH SI state x, control u,
    time t and its `node_pad`, each constraint's drift maps, the problem's length scale in
    m)."""
    return jnp.concatenate([c.values(x, u, t, pad, d, length)
                            for c, d in zip(constraints, drift)])


def violations(constraints, x, u, t, drift):
    """(n_c,) every constraint's SI violation at one point."""
    return jnp.stack([c.violation(x, u, t, d) for c, d in zip(constraints, drift)])
