"""Lambert's problem, any number of revolutions: the orbit from r1 to r2 in a given time.

Izzo's formulation (D. Izzo, "Revisiting Lambert's problem", Celest. Mech. Dyn. Astron. 121,
1-15, 2015). With c = |r2 - r1|, s = (|r1| + |r2| + c)/2, lambda^2 = 1 - c/s (lambda < 0 for
transfer angles above pi) and T = sqrt(2 mu / s^3) tof, the unknown x (x < 1: ellipse, x > 1:
hyperbola; a = s / (2 (1 - x^2))) solves T(x) = T with, for y = sqrt(1 - lambda^2 (1 - x^2)),

    T(x) = [(psi + M pi) / sqrt(|1 - x^2|) - x + lambda y] / (1 - x^2)       (Izzo eq. 18)

(hyperbola: psi -> -asinh(sqrt(x^2 - 1) (y - lambda x)), M = 0), where cos psi = x y +
lambda (1 - x^2), sin psi = sqrt(1 - x^2) (y - lambda x) (psi by atan2, accurate at every
angle). Near x = 1 this cancels, and Battin's series (Izzo eq. 20) is used instead:
T = (eta^3 Q + 4 lambda eta)/2 + M pi / |1 - x^2|^(3/2), eta = y - lambda x,
Q = 4/3 2F1(3, 1; 5/2; (1 - lambda - x eta)/2).

For M >= 1 revolutions T(x) is convex on (-1, 1) with a minimum T_min at x_Tmin (found by
Halley's method on T'(x) = 0): no solution when T < T_min, and two when T > T_min, the "left"
branch x < x_Tmin and the "right" branch x > x_Tmin (Izzo's naming). M = 0 has one solution
(x in (-1, inf)). Each root is found by Householder's third-order method (Izzo eq. 30) from
Izzo's starters, safeguarded by bisection inside its bracket; the derivatives of T are Izzo's closed
forms (eq. 22). The velocities follow from Izzo's Algorithm 1 (eqs. 7-8).

Direction: prograde transfers have angular momentum with a non-negative z component (the
inertial z axis); retrograde ones the opposite (the long way round). SI units: positions in m,
velocities in m/s, tof in s, mu in m^3/s^2, in an inertial frame.

Derivatives: x is differentiated by the implicit function theorem on T(x) - T = 0
(`jaxlpm.implicit.root`), so v1, v2 are differentiable in r1, r2, tof and mu.
"""

from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from .._validation import check_finite, check_shape, is_concrete, require_x64
from ..constants import MU_EARTH
from ..implicit import root
from ..status import Status

BRANCHES = {"left": 0, "right": 1}
SERIES_RADIUS = 0.1          # Battin's series for |x - 1| < 0.1: there |2F1 argument| <= 0.21
SERIES_TERMS = 28            # term 28 at z = 0.21 is ~1e-19: the truncation is below rounding
DEGENERATE_ANGLE = 1e-6      # rad: transfer angles this close to 0 or pi leave the plane undefined
MAX_ITERATIONS = 60          # Householder/Halley steps (bisection fallback needs ~50 at worst)
X_TOL = 1e-14                # a proposed |dx| <= X_TOL (1 + |x|) ends an iteration
T_RTOL = 1e-14               # |T(x) - T| <= T_RTOL T ends it too (~45 eps: T's rounding level)


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class LambertSolution:
    """Velocities v1 at r1 and v2 at r2 (m/s, inertial), Izzo's x, the iteration count and the
    status (`Status` code): SUCCESS; INVALID_INPUT (non-finite or zero positions, tof <= 0,
    mu <= 0 or non-finite, revolutions < 0); NONFINITE (velocities overflow); SINGULAR (transfer angle within DEGENERATE_ANGLE of 0 or pi: the
    transfer plane is undefined); INFEASIBLE (M >= 1 and tof below the M-revolution minimum
    time T_min(M): no such orbit); MAX_ITERATIONS. Failed solves return v1 = v2 = 0."""

    v1: jax.Array
    v2: jax.Array
    x: jax.Array
    iterations: jax.Array
    status: jax.Array


# (3)_k / (5/2)_k, the coefficients of 2F1(3, 1; 5/2; z), k = 0 .. SERIES_TERMS
_BATTIN_COEFFS = np.cumprod([1.0] + [(3.0 + k) / (2.5 + k) for k in range(SERIES_TERMS)])


def _hyp2f1_battin(z):
    """2F1(3, 1; 5/2; z) = sum_k (3)_k / (5/2)_k z^k, truncated after SERIES_TERMS terms
    (Horner's scheme)."""
    acc = _BATTIN_COEFFS[-1]
    for c in _BATTIN_COEFFS[-2::-1]:
        acc = acc * z + c
    return acc


def time_of_flight(x, lam, revolutions):
    """Izzo's nondimensional T(x) for lambda in [-1, 1] and M = revolutions >= 0 (see module
    doc)."""
    m = revolutions
    near = jnp.abs(x - 1.0) < SERIES_RADIUS
    ell = x < 1.0
    # Lancaster-Blanchard, ellipse (safe stand-in x = 0 where not used: keeps gradients finite)
    xe = jnp.where(ell & ~near, x, 0.0)
    ee = (1.0 - xe) * (1.0 + xe)
    ye = jnp.sqrt(1.0 - lam**2 * ee)
    sq = jnp.sqrt(ee)
    psi = jnp.arctan2(sq * (ye - lam * xe), xe * ye + lam * ee)
    t_ell = ((psi + m * jnp.pi) / sq - xe + lam * ye) / ee
    # hyperbola
    xh = jnp.where(~ell & ~near, x, 2.0)
    eh = (xh - 1.0) * (xh + 1.0)
    yh = jnp.sqrt(1.0 + lam**2 * eh)
    sh = jnp.sqrt(eh)
    t_hyp = (xh - lam * yh - jnp.arcsinh(sh * (yh - lam * xh)) / sh) / eh
    # Battin's series near x = 1
    t_ser = _series_time(jnp.where(near, x, 1.0 - 0.5 * SERIES_RADIUS), lam, m)
    return jnp.where(near, t_ser, jnp.where(ell, t_ell, t_hyp))


def _series_time(x, lam, m):
    """Battin's series branch of `time_of_flight` alone (valid for |x - 1| < SERIES_RADIUS)."""
    en = (1.0 - x) * (1.0 + x)
    eta = jnp.sqrt(1.0 - lam**2 * en) - lam * x
    q = 4.0 / 3.0 * _hyp2f1_battin(0.5 * (1.0 - lam - x * eta))
    en_rev = jnp.where(m > 0, jnp.abs(en), 1.0)       # M = 0 may sit at x = 1 exactly
    return 0.5 * (eta**3 * q + 4.0 * lam * eta) + jnp.where(m > 0, m * jnp.pi / en_rev**1.5, 0.0)


def _battin_taylor(z):
    """2F1(3, 1; 5/2; z) and its first three z-derivatives: Horner's scheme carrying the
    Taylor coefficients of the truncated series at z (repeated synthetic division; unrolled,
    so that XLA fuses it, as `_hyp2f1_battin`)."""
    p0, p1, p2, p3 = _BATTIN_COEFFS[-1], 0.0, 0.0, 0.0
    for c in _BATTIN_COEFFS[-2::-1]:
        p0, p1, p2, p3 = p0 * z + c, p1 * z + p0, p2 * z + p1, p3 * z + p2
    return p0, p1, 2.0 * p2, 6.0 * p3


def _series_derivatives(x, lam, m):
    """`_series_time` and its first three x-derivatives by the chain and product rules
    (Faa di Bruno to third order) through y = sqrt(1 - lambda^2 (1 - x^2)), eta = y -
    lambda x, z = (1 - lambda - x eta) / 2, Q = 4/3 2F1(z) (`_battin_taylor`) and the
    M pi |1 - x^2|^(-3/2) term, with y' = lambda^2 x / y, y'' = lambda^2 (1 - lambda^2) / y^3,
    y''' = -3 y'' y' / y. Exact, no cancellation at x = 1 (nothing divides by 1 - x^2 there
    for M = 0); written out instead of Taylor-mode autodiff (jax.experimental.jet), whose
    program was 3/4 of the whole Lambert solver's (issue 21)."""
    l2 = lam**2
    y = jnp.sqrt(1.0 - l2 * (1.0 - x) * (1.0 + x))
    y1 = l2 * x / y
    y2 = l2 * (1.0 - l2) / y**3
    y3 = -3.0 * y2 * y1 / y
    e0, e1, e2, e3 = y - lam * x, y1 - lam, y2, y3                          # eta
    z1, z2, z3 = -0.5 * (e0 + x * e1), -0.5 * (2.0 * e1 + x * e2), -0.5 * (3.0 * e2 + x * e3)
    f0, f1, f2, f3 = _battin_taylor(0.5 * (1.0 - lam - x * e0))
    q = (f0, f1 * z1, f2 * z1**2 + f1 * z2, f3 * z1**3 + 3.0 * f2 * z1 * z2 + f1 * z3)
    q0, q1, q2, q3 = (4.0 / 3.0 * qk for qk in q)
    p0, p1 = e0**3, 3.0 * e0**2 * e1                                         # eta^3
    p2 = 6.0 * e0 * e1**2 + 3.0 * e0**2 * e2
    p3 = 6.0 * e1**3 + 18.0 * e0 * e1 * e2 + 3.0 * e0**2 * e3
    a = (p0 * q0, p1 * q0 + p0 * q1, p2 * q0 + 2.0 * p1 * q1 + p0 * q2,
         p3 * q0 + 3.0 * p2 * q1 + 3.0 * p1 * q2 + p0 * q3)
    # M pi e^(-3/2), e = |1 - x^2| = sign (1 - x^2): e' = -2 x sign, e'' = -2 sign, e''' = 0
    en = (1.0 - x) * (1.0 + x)
    sign = jnp.where(en < 0.0, -1.0, 1.0)
    e = jnp.where(m > 0, jnp.abs(en), 1.0)        # M = 0 may sit at x = 1 exactly
    d1, d2 = -2.0 * x * sign, -2.0 * sign
    g0, g1, g2, g3 = e**-1.5, -1.5 * e**-2.5, 3.75 * e**-3.5, -13.125 * e**-4.5
    r = (g0, g1 * d1, g2 * d1**2 + g1 * d2, g3 * d1**3 + 3.0 * g2 * d1 * d2)
    mpi = jnp.where(m > 0, m * jnp.pi, 0.0)
    return tuple(0.5 * (a[k] + 4.0 * lam * ek) + mpi * r[k]
                 for k, ek in enumerate((e0, e1, e2, e3)))


def _derivatives(x, lam, m):
    """T and its x-derivatives T1, T2, T3. Away from x = 1: Izzo eq. 22, with
    y = sqrt(1 - lambda^2 (1 - x^2)), d = 1 - x^2,
    T1 = (3 T x - 2 + 2 lambda^3 x / y) / d, T2 = (3 T + 5 x T1 + 2 (1 - lambda^2) lambda^3 /
    y^3) / d, T3 = (7 x T2 + 8 T1 - 6 (1 - lambda^2) lambda^5 x / y^5) / d. These divide by
    d -> 0 at x = 1, so inside the series radius the derivatives are those of Battin's series
    itself (`_series_derivatives`: exact, no cancellation)."""
    t = time_of_flight(x, lam, m)
    near = jnp.abs(x - 1.0) < SERIES_RADIUS
    xf = jnp.where(near, 0.0, x)                       # stand-in keeps the closed forms finite
    tf = jnp.where(near, 1.0, t)
    d = (1.0 - xf) * (1.0 + xf)
    y = jnp.sqrt(1.0 - lam**2 * d)
    l2, l3 = lam**2, lam**3
    t1 = (3.0 * tf * xf - 2.0 + 2.0 * l3 * xf / y) / d
    t2 = (3.0 * tf + 5.0 * xf * t1 + 2.0 * (1.0 - l2) * l3 / y**3) / d
    t3 = (7.0 * xf * t2 + 8.0 * t1 - 6.0 * (1.0 - l2) * l3 * l2 * xf / y**5) / d
    _, s1, s2, s3 = _series_derivatives(jnp.where(near, x, 1.0), lam, m)
    return (t, jnp.where(near, s1, t1), jnp.where(near, s2, t2), jnp.where(near, s3, t3))


def _bracketed(step, x0, lo, hi, increasing, g_tol):
    """Root of g on (lo, hi) by `step(x) -> (g(x), proposed x)`, falling back to bisection
    whenever the proposal leaves the bracket (hi = inf: doubling). g increasing or decreasing.

    Stops when |g| <= g_tol (the residual is at rounding level: this is what decides near a
    flat minimum of T, where steps stay noisy) or when the proposed step is below
    X_TOL (1 + |x|) (then the proposal is taken). Testing the proposal before the bracket
    keeps a converged iterate from being thrown to the bracket's midpoint by rounding noise.
    Returns (x, iterations, converged)."""

    def cond(c):
        _, _, _, it, done = c
        return (it < MAX_ITERATIONS) & ~done

    def body(c):
        x, lo, hi, it, _ = c
        g, xp = step(x)
        below = jnp.where(increasing, g < 0.0, g > 0.0)
        lo, hi = jnp.where(below, x, lo), jnp.where(below, hi, x)
        finite = jnp.isfinite(xp)
        inside = (xp > lo) & (xp < hi) & finite
        small_step = finite & (jnp.abs(xp - x) <= X_TOL * (1.0 + jnp.abs(x)))
        done = (jnp.abs(g) <= g_tol) | small_step
        fallback = jnp.where(jnp.isfinite(hi), 0.5 * (lo + hi), 2.0 * jnp.abs(x) + 1.0)
        x_new = jnp.where(done, jnp.where(small_step, xp, x), jnp.where(inside, xp, fallback))
        return x_new, lo, hi, it + 1, done

    x0 = jnp.where((x0 > lo) & (x0 < hi), x0, jnp.where(jnp.isfinite(hi), 0.5 * (lo + hi), x0))
    x, _, _, it, done = jax.lax.while_loop(cond, body, (x0, lo, hi, 0, jnp.asarray(False)))
    return x, it, done


def minimum_time(lam, revolutions):
    """(x_Tmin, T_min) of the M = revolutions >= 1 time curve: Halley's method on T'(x) = 0
    in (-1, 1) (Izzo §3), T convex there. Returns (x, T, iterations, converged)."""
    m = revolutions

    def halley(x):
        _, t1, t2, t3 = _derivatives(x, lam, m)
        return t1, x - 2.0 * t1 * t2 / (2.0 * t2**2 - t1 * t3)

    x, it, ok = _bracketed(halley, jnp.zeros_like(lam), -1.0, 1.0, True, 0.0)
    return x, time_of_flight(x, lam, m), it, ok


def _initial_guess(lam, T, m, right):
    """Izzo's starters (§3, eq. 30 and the M >= 1 pair)."""
    t00 = jnp.arccos(lam) + lam * jnp.sqrt(1.0 - lam**2)
    t1 = 2.0 / 3.0 * (1.0 - lam**3)
    x_long = -(T - t00) / (T - t00 + 4.0)
    x_short = t1 * (t1 - T) / (0.4 * (1.0 - lam**5) * T) + 1.0
    x_mid = (T / t00) ** (jnp.log(2.0) / jnp.log(t1 / t00)) - 1.0
    x_single = jnp.where(T >= t00, x_long, jnp.where(T <= t1, x_short, x_mid))
    m1 = jnp.maximum(m, 1.0)
    tl = ((m1 * jnp.pi + jnp.pi) / (8.0 * T)) ** (2.0 / 3.0)
    tr = (8.0 * T / (m1 * jnp.pi)) ** (2.0 / 3.0)
    x_multi = jnp.where(right, (tr - 1.0) / (tr + 1.0), (tl - 1.0) / (tl + 1.0))
    return jnp.where(m > 0, x_multi, x_single)


def _time_residual(x, lam, T, m, right, x_tmin):
    return time_of_flight(x, lam, m) - T


@root(_time_residual, has_aux=True, zero_nonfinite=True)
def _solve_x(x_init, lam, T, m, right, x_tmin):
    """x with T(x; lam, m) = T on its branch; (x, (iterations, converged))."""
    del x_init
    multi = m > 0
    lo = jnp.where(multi & right, x_tmin, -1.0)
    hi = jnp.where(multi, jnp.where(right, 1.0, x_tmin), jnp.inf)
    increasing = multi & right

    def householder(x):
        t, t1, t2, t3 = _derivatives(x, lam, m)
        d = t - T
        step = d * (t1**2 - 0.5 * d * t2) / (t1 * (t1**2 - d * t2) + t3 * d**2 / 6.0)
        return d, x - step

    x, it, ok = _bracketed(householder, _initial_guess(lam, T, m, right), lo, hi, increasing,
                           T_RTOL * T)
    return x, (it, ok)


def _geometry(r1, r2, prograde):
    """(lambda, s, c, unit r1, unit r2, unit transverse t1, t2, transfer plane defined)."""
    r1n, r2n = jnp.linalg.norm(r1), jnp.linalg.norm(r2)
    c = jnp.linalg.norm(r2 - r1)
    s = 0.5 * (r1n + r2n + c)
    ir1, ir2 = r1 / r1n, r2 / r2n
    h = jnp.cross(ir1, ir2)
    hn = jnp.linalg.norm(h)
    angle = jnp.arctan2(hn, jnp.dot(ir1, ir2))           # in [0, pi]
    planar = (angle > DEGENERATE_ANGLE) & (angle < jnp.pi - DEGENERATE_ANGLE)
    ih = h / jnp.where(planar, hn, 1.0)
    lam = jnp.sqrt(jnp.maximum(1.0 - c / s, 0.0))
    # the short way (angle < pi) is prograde when h_z >= 0; otherwise go the long way round
    flip = (ih[2] < 0.0) != ~prograde
    sign = jnp.where(flip, -1.0, 1.0)
    it1 = sign * jnp.cross(ih, ir1)
    it2 = sign * jnp.cross(ih, ir2)
    return sign * lam, s, c, r1n, r2n, ir1, ir2, it1, it2, planar


def _lambert(r1, r2, tof, revolutions, branch, prograde, mu):
    m = jnp.asarray(revolutions).astype(r1.dtype)        # Izzo's M
    right = jnp.asarray(branch) == 1
    valid = (jnp.all(jnp.isfinite(r1)) & jnp.all(jnp.isfinite(r2)) & jnp.isfinite(tof)
             & (tof > 0.0) & jnp.isfinite(mu) & (mu > 0.0) & (jnp.linalg.norm(r1) > 0.0)
             & (jnp.linalg.norm(r2) > 0.0) & (m >= 0.0))
    # safe stand-ins keep every branch finite (and its gradient) when the input is invalid
    r1 = jnp.where(valid, r1, jnp.array([1.0, 0.0, 0.0]))
    r2 = jnp.where(valid, r2, jnp.array([0.0, 1.0, 0.0]))
    tof, mu, m = (jnp.where(valid, tof, 1.0), jnp.where(valid, mu, 1.0),
                  jnp.where(valid, m, 0.0))
    lam, s, c, r1n, r2n, ir1, ir2, it1, it2, planar = _geometry(r1, r2, prograde)
    T = jnp.sqrt(2.0 * mu / s**3) * tof
    x_tmin, t_min, it_min, ok_min = minimum_time(jax.lax.stop_gradient(lam), m)
    feasible = (m == 0.0) | (T > t_min)
    good = valid & planar & feasible
    T_solve = jnp.where(good, T, jax.lax.stop_gradient(2.0 * t_min + 1.0))
    x, (it, ok) = _solve_x(0.0 * T, lam, T_solve, m, right, jax.lax.stop_gradient(x_tmin))
    ok = ok & ((m == 0.0) | ok_min)
    # velocities, Izzo Algorithm 1
    gamma = jnp.sqrt(0.5 * mu * s)
    rho = (r1n - r2n) / c
    sigma = jnp.sqrt(1.0 - rho**2)
    y = jnp.sqrt(1.0 - lam**2 * (1.0 - x) * (1.0 + x))
    vr1 = gamma * ((lam * y - x) - rho * (lam * y + x)) / r1n
    vr2 = -gamma * ((lam * y - x) + rho * (lam * y + x)) / r2n
    vt = gamma * sigma * (y + lam * x)
    v1 = vr1 * ir1 + vt / r1n * it1
    v2 = vr2 * ir2 + vt / r2n * it2
    finite = jnp.all(jnp.isfinite(v1)) & jnp.all(jnp.isfinite(v2)) & jnp.isfinite(x)
    status = jnp.select([~valid, ~planar, ~feasible, ~ok, ~finite],
                        [Status.INVALID_INPUT, Status.SINGULAR, Status.INFEASIBLE,
                         Status.MAX_ITERATIONS, Status.NONFINITE],
                        Status.SUCCESS).astype(jnp.int32)
    keep = status == Status.SUCCESS
    return LambertSolution(v1=jnp.where(keep, v1, 0.0), v2=jnp.where(keep, v2, 0.0),
                           x=x, iterations=it + jnp.where(m > 0, it_min, 0), status=status)


def _check(r1, r2, tof, revolutions, branch, mu):
    for name, r in (("r1", r1), ("r2", r2)):
        check_shape(name, r, (3,))
        if np.linalg.norm(check_finite(name, r)) == 0.0:
            raise ValueError(f"{name} must be a non-zero position vector (m), got {r!r}")
    for name, val in (("tof", tof), ("mu", mu)):
        check_shape(name, val, ())
        v = float(check_finite(name, val))
        if v <= 0.0:
            raise ValueError(f"{name} must be positive, got {v}")
    m = np.asarray(revolutions)
    if m.shape != () or m != np.round(m) or m < 0:
        raise ValueError(f"revolutions must be an integer >= 0, got {revolutions!r}")
    if np.shape(branch) != () or int(branch) not in (0, 1):
        raise ValueError(f"branch must be 'left', 'right', 0 or 1, got {branch!r}")


def lambert(r1, r2, tof, revolutions=0, branch="left", prograde=True, mu=MU_EARTH):
    """Solve Lambert's problem for one (r1, r2, tof): Izzo 2015, M = `revolutions` full turns.

    r1, r2: inertial positions (m); tof: time of flight (s) > 0; mu (m^3/s^2). branch: "left"
    (x < x_Tmin) or "right" (x > x_Tmin), or 0 / 1 (array-valued under vmap); ignored for
    M = 0. prograde: angular momentum z >= 0 (else the other way round). Returns a
    `LambertSolution` (v1, v2 in m/s). Concrete bad input raises ValueError; traced bad input
    gives status INVALID_INPUT; a transfer angle within 1e-6 rad of 0 or pi (plane undefined)
    gives SINGULAR and tof < T_min(M) gives INFEASIBLE, concrete or not (see `LambertSolution`).
    Differentiable in reverse mode (jax.grad / jacrev: jaxopt's implicit rule is a custom_vjp).
    """
    require_x64()
    if isinstance(branch, str):
        if branch not in BRANCHES:
            raise ValueError(f"branch must be 'left' or 'right', got {branch!r}")
        branch = BRANCHES[branch]
    if is_concrete(r1, r2, tof, revolutions, branch, mu):
        _check(r1, r2, tof, revolutions, branch, mu)
    f = lambda v: jnp.asarray(v, dtype=jnp.float64)
    return _lambert(f(r1), f(r2), f(tof), jnp.asarray(revolutions), jnp.asarray(branch),
                    jnp.asarray(prograde, dtype=bool), f(mu))
