"""Tests of jaxlpm.orbits.lambert (Izzo 2015, multi-revolution Lambert).

Independent references: Kepler propagation of the solution's elements (jaxlpm.orbits.kepler,
elliptic) and scipy's DOP853 at rtol 1e-13 (hyperbolic and near-parabolic transfers); the
classical Lagrange time equation in NumPy, minimised by scipy, for the M-revolution minimum
time; central finite differences for the implicit derivatives. One batch of problems goes
through one jit(vmap(lambert)) compiled once per module.
"""

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp
import numpy as np
import pytest
from jax.experimental.jet import jet
from scipy.integrate import solve_ivp
from scipy.optimize import minimize_scalar

from jaxlpm.constants import MU_EARTH
from jaxlpm.orbits import elements_to_state, state_to_elements, true_anomaly_from_time
from jaxlpm.orbits import lambert as lambert_module
from jaxlpm.orbits.lambert import lambert
from jaxlpm.status import Status

MU = MU_EARTH
PI = np.pi
# Hit tolerance, relative to |r2|: the solver ends at |T(x) - T| <= 1e-14 T, i.e. a timing
# error ~1e-14 tof, which moves the arrival point by ~1e-14 of the distance flown (< 1e-12
# |r2| for the <= 4.5 revolutions here); the references add ~1e-12 (Kepler's equation at high
# e, DOP853 at rtol 1e-13 over several revolutions). 1e-9 leaves margin for the
# ill-conditioned high-e and near-pi cases and is 1000x tighter than the 1e-6.
HIT_RTOL = 1e-9


def _unit(rng, n):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _rotate_towards(u, w, angle):
    """Unit vectors at `angle` from unit u, in the plane of u and w."""
    p = w - np.sum(w * u, axis=1, keepdims=True) * u
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    return np.cos(angle)[:, None] * u + np.sin(angle)[:, None] * p


def lagrange_tof(x, lam, revolutions):
    """Nondimensional T(x) of an ellipse (|x| < 1) from Lagrange's equation with a = 1/(1-x^2),
    alpha = 2 acos x, beta = 2 asin(lambda sqrt(1 - x^2)): T = a^(3/2) [alpha - sin alpha -
    (beta - sin beta) + 2 pi M] / 2, written independently of the solver's Lancaster form."""
    a = 1.0 / (1.0 - x * x)
    alpha = 2.0 * np.arccos(x)
    beta = 2.0 * np.arcsin(lam * np.sqrt(1.0 - x * x))
    return a**1.5 * ((alpha - np.sin(alpha)) - (beta - np.sin(beta)) + 2.0 * PI * revolutions) / 2.0


def reference_min_tof(r1, r2, revolutions, prograde):
    """M-revolution minimum time of flight (s) by bounded scalar minimisation of Lagrange's T."""
    r1n, r2n = np.linalg.norm(r1), np.linalg.norm(r2)
    c = np.linalg.norm(r2 - r1)
    s = 0.5 * (r1n + r2n + c)
    lam = np.sqrt(1.0 - c / s)
    short = (np.cross(r1, r2)[2] >= 0.0) == prograde      # angle < pi the chosen way round
    lam = lam if short else -lam
    res = minimize_scalar(lambda x: lagrange_tof(x, lam, revolutions),
                          bounds=(-1 + 1e-12, 1 - 1e-12),
                          method="bounded", options={"xatol": 1e-12})
    return res.fun / np.sqrt(2.0 * MU / s**3)


def dop853(r1, v1, tof):
    """Two-body propagation by scipy DOP853 at rtol 1e-13 (the independent integrator)."""
    f = lambda t, y: np.r_[y[3:], -MU * y[:3] / np.linalg.norm(y[:3]) ** 3]
    sol = solve_ivp(f, (0.0, tof), np.r_[r1, v1], method="DOP853", rtol=1e-13, atol=1e-9)
    return sol.y[:3, -1], sol.y[3:, -1]


def _kepler_fly(r1, v1, tof):
    orbit = state_to_elements(r1, v1, MU)
    r, v = elements_to_state(orbit, true_anomaly_from_time(orbit, tof))
    return r, v, orbit.a


def _make_batch():
    """Random geometries (6600-42000 km), M = 0..3, both branches, both directions, with tofs
    from below T_min(M) to several periods; plus near-pi, exactly-pi, collinear and
    near-parabolic members. Returns a dict of arrays and a dict of index groups."""
    rng = np.random.default_rng(20260601)
    n = 240
    u1 = _unit(rng, n)
    r1 = u1 * rng.uniform(6.6e6, 4.2e7, (n, 1))
    r2 = _unit(rng, n) * rng.uniform(6.6e6, 4.2e7, (n, 1))
    revolutions = rng.integers(0, 4, n)
    branch = rng.integers(0, 2, n)
    prograde = rng.integers(0, 2, n).astype(bool)
    rmax = np.maximum(np.linalg.norm(r1, axis=1), np.linalg.norm(r2, axis=1))
    period = 2 * PI * np.sqrt(rmax**3 / MU)
    tof = period * (revolutions + 1) * rng.uniform(0.15, 1.5, n)
    groups = {"random": np.arange(n)}
    # near pi: transfer angles pi - delta (delta > 1e-6 solvable; below, no plane: SINGULAR)
    deltas = np.array([1e-2, 1e-4, 1e-5, 3e-6, 5e-7, 0.0])
    k = len(deltas) * 2
    base = np.repeat(np.array([[7.0e6, 1.0e6, 2.0e5]]), k, 0)
    w = np.repeat(np.array([[0.0, 0.3, 1.0]]), k, 0)
    ub = base / np.linalg.norm(base, axis=1, keepdims=True)
    ang = PI - np.tile(deltas, 2)
    r2_pi = _rotate_towards(ub, w, ang) * 2.1e7
    m_pi = np.repeat([0, 2], len(deltas))
    groups["near_pi"] = n + np.arange(k)
    # collinear, same direction (transfer angle 0): SINGULAR
    r1_c, r2_c = np.array([[7e6, 1e6, 2e5]]), np.array([[7e6, 1e6, 2e5]]) * 3.0
    # near-parabolic (M = 0, x ~ 1): tofs around the parabolic time of an r1 -> r2 pair
    ra, rb = np.array([7.0e6, 0.0, 0.0]), 1.2e7 * np.array([np.cos(1.0), np.sin(1.0), 0.3])
    cp = np.linalg.norm(rb - ra)
    sp = 0.5 * (np.linalg.norm(ra) + np.linalg.norm(rb) + cp)
    lp = np.sqrt(1 - cp / sp)
    t_par = 2.0 / 3.0 * (1 - lp**3) / np.sqrt(2 * MU / sp**3)   # Euler's parabolic time
    tofs_p = t_par * np.array([1 - 1e-3, 1 - 1e-8, 1.0, 1 + 1e-8, 1 + 1e-3, 0.3])
    kp = len(tofs_p)
    groups["collinear"] = np.array([n + k])
    groups["parabolic"] = n + k + 1 + np.arange(kp)
    cat = lambda *a: np.concatenate(a)
    data = dict(
        r1=cat(r1, base, r1_c, np.repeat(ra[None], kp, 0)),
        r2=cat(r2, r2_pi, r2_c, np.repeat(rb[None], kp, 0)),
        tof=cat(tof, 4.0e4 * (m_pi + 1), [3.0e4], tofs_p),
        revolutions=cat(revolutions, m_pi, [0], np.zeros(kp, int)),
        branch=cat(branch, np.tile([0, 1], k // 2), [0], np.zeros(kp, int)),
        prograde=cat(prograde, np.ones(k, bool), [True], np.ones(kp, bool)),
    )
    return data, groups, deltas


@pytest.fixture(scope="module")
def batch():
    data, groups, deltas = _make_batch()
    solve = jax.jit(jax.vmap(lambda r1, r2, t, m, b, p: lambert(r1, r2, t, m, b, p)))
    sol = solve(data["r1"], data["r2"], data["tof"], data["revolutions"], data["branch"],
                data["prograde"])
    sol = jax.tree_util.tree_map(np.asarray, sol)
    fly = jax.jit(jax.vmap(_kepler_fly))
    return data, groups, deltas, sol, fly


def test_random_geometries_hit_r2(batch):
    data, groups, _, sol, fly = batch
    idx = groups["random"]
    st = sol.status[idx]
    assert set(np.unique(st)) <= {Status.SUCCESS, Status.INFEASIBLE}
    ok = idx[st == Status.SUCCESS]
    assert len(ok) > 150                                   # most of the batch is feasible
    assert np.all(sol.status[idx][data["revolutions"][idx] == 0] == Status.SUCCESS)
    v1 = sol.v1[ok]
    energy = 0.5 * np.sum(v1**2, 1) - MU / np.linalg.norm(data["r1"][ok], axis=1)
    ell = ok[energy < 0]
    r, v, a = (np.asarray(z) for z in fly(data["r1"][ell], sol.v1[ell], data["tof"][ell]))
    r2 = data["r2"][ell]
    assert np.max(np.linalg.norm(r - r2, axis=1) / np.linalg.norm(r2, axis=1)) < HIT_RTOL
    dv = np.linalg.norm(v - sol.v2[ell], axis=1) / np.linalg.norm(sol.v2[ell], axis=1)
    assert np.max(dv) < HIT_RTOL
    # M full revolutions: the flight takes between M and M + 1 periods of the transfer orbit
    periods = data["tof"][ell] / (2 * PI * np.sqrt(a**3 / MU))
    assert np.all(np.floor(periods) == data["revolutions"][ell])
    # direction: angular momentum z >= 0 for prograde transfers, < 0 for retrograde
    hz = np.cross(data["r1"][ok], v1)[:, 2]
    assert np.all((hz >= 0) == data["prograde"][ok])
    # the hyperbolic members, if any, by DOP853
    for i in ok[energy >= 0][:3]:
        r_end, _ = dop853(data["r1"][i], sol.v1[i], data["tof"][i])
        assert np.linalg.norm(r_end - data["r2"][i]) < HIT_RTOL * np.linalg.norm(data["r2"][i])


def test_branches_are_distinct_solutions(batch):
    data, groups, _, sol, _ = batch
    idx = groups["random"]
    multi = idx[(data["revolutions"][idx] > 0) & (sol.status[idx] == Status.SUCCESS)]
    left, right = multi[data["branch"][multi] == 0], multi[data["branch"][multi] == 1]
    assert len(left) > 20 and len(right) > 20
    # Izzo's x: left branch below x_Tmin, right above; x_Tmin lies in (-1, 1), so on average
    # the two branches are well separated, and each lies in (-1, 1) (ellipses)
    assert np.all(np.abs(sol.x[multi]) < 1.0)
    assert np.mean(sol.x[left]) < np.mean(sol.x[right])


def test_infeasible_revolutions_match_minimum_time(batch):
    """INFEASIBLE exactly when tof < T_min(M), T_min from the independent Lagrange form."""
    data, groups, _, sol, _ = batch
    idx = groups["random"]
    multi = idx[data["revolutions"][idx] > 0]
    assert np.any(sol.status[multi] == Status.INFEASIBLE)
    for i in multi:
        tmin = reference_min_tof(data["r1"][i], data["r2"][i], data["revolutions"][i],
                                 data["prograde"][i])
        # bounded Brent finds T_min to ~1e-10 relative (flat minimum: x to 1e-6, T to x^2)
        margin = abs(data["tof"][i] / tmin - 1.0)
        if margin > 1e-8:
            expected = Status.INFEASIBLE if data["tof"][i] < tmin else Status.SUCCESS
            assert sol.status[i] == expected, (i, data["tof"][i], tmin)


def test_near_pi_and_collinear(batch):
    data, groups, deltas, sol, _ = batch
    idx = groups["near_pi"]
    solvable = np.tile(deltas, 2) > 1e-6
    assert np.all(sol.status[idx[~solvable]] == Status.SINGULAR)
    assert np.all(sol.v1[idx[~solvable]] == 0.0)
    assert np.all(sol.status[idx[solvable]] == Status.SUCCESS)
    for i in idx[solvable]:
        r_end, v_end = dop853(data["r1"][i], sol.v1[i], data["tof"][i])
        # within 3e-6 rad of pi the plane normal r1 x r2 / |r1 x r2| carries eps / 3e-6 ~ 1e-10
        # relative error, inside HIT_RTOL
        assert np.linalg.norm(r_end - data["r2"][i]) < HIT_RTOL * np.linalg.norm(data["r2"][i])
    assert sol.status[groups["collinear"][0]] == Status.SINGULAR


def test_near_parabolic(batch):
    data, groups, _, sol, _ = batch
    idx = groups["parabolic"]
    assert np.all(sol.status[idx] == Status.SUCCESS)
    x = sol.x[idx]
    # tof = t_par (1 -+ 1e-8): x within ~1e-8 of 1 on either side (dT/dx = O(1) there)
    assert np.all(np.abs(x[1:4] - 1.0) < 1e-6)
    assert x[1] > 1.0 > x[3]                   # shorter than parabolic: hyperbola (x > 1)
    for i in idx:
        r_end, v_end = dop853(data["r1"][i], sol.v1[i], data["tof"][i])
        assert np.linalg.norm(r_end - data["r2"][i]) < HIT_RTOL * np.linalg.norm(data["r2"][i])
        assert np.linalg.norm(v_end - sol.v2[i]) < HIT_RTOL * np.linalg.norm(sol.v2[i])


def test_series_derivatives_equal_taylor_mode_autodiff():
    """Battin's series branch of T(x) and its first three derivatives, written out by the
    chain rule (`_series_derivatives`), against Taylor-mode autodiff of the series itself
    (jax.experimental.jet) inside its radius, for transfer angles above and below pi and
    M = 0, 1, 3 (M >= 1 on the ellipse side only). Both are exact to rounding: the largest
    terms, M pi |1 - x^2|^(-9/2) ~ 1e9 at x = 0.9, carry ~1e-16 relative error each, so 1e-12
    relative to 1 + |T^(k)|."""
    def one(x, lam, m):
        ref = jet(lambda z: lambert_module._series_time(z, lam, m), (x,),
                  ((jnp.ones_like(x), jnp.zeros_like(x), jnp.zeros_like(x)),))
        return jnp.stack([ref[0], *ref[1]]), jnp.stack(
            lambert_module._series_derivatives(x, lam, m))

    x = jnp.linspace(0.901, 1.099, 23)
    for lam in (-0.99, -0.5, 0.0, 0.3, 0.9, 0.999):
        for m in (0.0, 1.0, 3.0):
            xs = x[x < 1.0] if m > 0 else x
            ref, ours = jax.jit(jax.vmap(one, in_axes=(0, None, None)))(xs, lam, m)
            np.testing.assert_array_less(np.abs(ours - ref) / (1.0 + np.abs(ref)), 1e-12)


def _velocities(r1, r2, tof, revolutions, branch):
    s = lambert(r1, r2, tof, revolutions, branch)
    return jnp.concatenate([s.v1, s.v2]), s.status


# revolutions and branch are traced arguments: one compilation serves every case below
_vel = jax.jit(_velocities)
_jac = jax.jit(jax.jacrev(lambda *a: _velocities(*a)[0], argnums=(0, 1, 2)))


@pytest.mark.parametrize("revolutions,branch", [(0, 0), (2, 1), (1, 0)])
def test_gradient_matches_central_differences(revolutions, branch):
    """Implicit derivatives of (v1, v2) w.r.t. r1, r2 and tof against central differences.

    Steps: 10 m on positions of ~1e7 m and 1e-6 tof, so the truncation error h^2 |v'''| / 6 is
    ~1e-12 relative and rounding eps |v| / h ~ 1e-9 relative; 1e-6 bounds both."""
    r1 = np.array([7.0e6, 1.0e5, 2.0e4])
    r2 = 1.2e7 * np.array([np.cos(2.0), np.sin(2.0), 0.3])
    tof = 5.0e3 + 4.0e4 * revolutions
    f = lambda a, b, t: np.asarray(_vel(a, b, t, revolutions, branch)[0])
    assert int(_vel(r1, r2, tof, revolutions, branch)[1]) == Status.SUCCESS
    jr1, jr2, jt = _jac(r1, r2, tof, revolutions, branch)
    h, ht = 10.0, 1e-6 * tof
    fd1 = np.stack([(f(r1 + h * e, r2, tof) - f(r1 - h * e, r2, tof)) / (2 * h)
                    for e in np.eye(3)], 1)
    fd2 = np.stack([(f(r1, r2 + h * e, tof) - f(r1, r2 - h * e, tof)) / (2 * h)
                    for e in np.eye(3)], 1)
    fdt = (f(r1, r2, tof + ht) - f(r1, r2, tof - ht)) / (2 * ht)
    for jac, fd in ((jr1, fd1), (jr2, fd2), (jt, fdt)):
        assert np.max(np.abs(np.asarray(jac) - fd)) < 1e-6 * np.max(np.abs(fd))


def test_invalid_input():
    r1, r2 = np.array([7e6, 0.0, 0.0]), np.array([0.0, 8e6, 0.0])
    with pytest.raises(ValueError, match="tof"):
        lambert(r1, r2, -1.0)
    with pytest.raises(ValueError, match="revolutions"):
        lambert(r1, r2, 1e4, revolutions=1.5)
    with pytest.raises(ValueError, match="branch"):
        lambert(r1, r2, 1e4, branch="middle")
    with pytest.raises(ValueError, match="r1"):
        lambert(np.zeros(3), r2, 1e4)
    # traced: a status, zero outputs and finite (zero) gradients instead of an exception
    g = jax.jit(jax.grad(lambda t: jnp.sum(lambert(r1, r2, t).v1)))(-1.0)
    s = jax.jit(lambda t: lambert(r1, r2, t))(-1.0)
    assert int(s.status) == Status.INVALID_INPUT and np.all(np.asarray(s.v1) == 0.0)
    assert np.isfinite(float(g))
