"""Property-based guard over the public entry points (issue 17): random values, NaN, inf,
zero, negative, huge, wrong shapes and dtypes, concrete and traced under jit(vmap).

Properties, for every call:
- concrete input either raises ValueError whose message names a perturbed field, or returns
  a result with a status; traced input (vmap over [valid, perturbed]) always returns one;
- no other exception type, ever;
- an output whose status is SUCCESS is finite; the valid member of a batch stays SUCCESS;
- input that raises when concrete gives INVALID_INPUT when traced (one list of checks);
- no hang: each example runs under a watchdog that kills the process (with tracebacks) after
  `LIMIT_S` seconds.

CI runs a few examples per entry point, derandomized (`JAXLPM_PROPERTY_EXAMPLES`, default 6);
`experiments/property_battery.py` runs the long, random version and records the result.
"""

import faulthandler
import os
from contextlib import contextmanager

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

import jaxlpm as lpm
from jaxlpm.collocation.segments import uniform_breaks
from jaxlpm.dynamics import hcw_matrix
from jaxlpm.dynamics.propagation import propagate
from jaxlpm.orbits.lambert import lambert
from jaxlpm.status import Status

# small grids for speed: solutions that converge unresolved are accepted (conftest)
pytestmark = pytest.mark.usefixtures("loose_accuracy")

EXAMPLES = int(os.environ.get("JAXLPM_PROPERTY_EXAMPLES", "6"))
LIMIT_S = float(os.environ.get("JAXLPM_PROPERTY_LIMIT_S", "300"))
SETTINGS = settings(max_examples=EXAMPLES, deadline=None, database=None,
                    derandomize="JAXLPM_PROPERTY_SEED" not in os.environ,
                    suppress_health_check=list(HealthCheck))
STATUS_CODES = {int(s) for s in Status}


@contextmanager
def watchdog():
    """Kill the process, dumping every thread's traceback, if the body runs past LIMIT_S: a
    hang inside XLA never returns to Python, so a Python-level timeout could not end it."""
    faulthandler.dump_traceback_later(LIMIT_S, exit=True)
    try:
        yield
    finally:
        faulthandler.cancel_dump_traceback_later()


# ---- the entry points: a flat dict of named inputs, a builder, a call ------------------------

ORBIT_E = lpm.KeplerOrbit(a=9500e3, e=0.3, i=0.5, raan=0.3, argp=0.2, f0=0.1)
X0 = np.array([10e3, 10e3, 100.0, 4.0, -23.485, 0.1])


def _orbit(d):
    return lpm.KeplerOrbit(a=d["orbit.a"], e=d["orbit.e"], i=d["orbit.i"], raan=d["orbit.raan"],
                           argp=d["orbit.argp"], f0=d["orbit.f0"], mu=d["orbit.mu"])


def _orbit_fields(orbit):
    return {f"orbit.{k}": float(getattr(orbit, k)) for k in
            ("a", "e", "i", "raan", "argp", "f0", "mu")}


def _transfer(model):
    def build(d):
        return lpm.EnergyOptimalTransfer(_orbit(d), d["x0"], d["xf"], d["duration"],
                                         model=model, j2=d["j2"], r_eq=d["r_eq"])
    return build


TRANSFER_BASE = {**_orbit_fields(ORBIT_E), "x0": X0, "xf": np.zeros(6),
                 "duration": float(ORBIT_E.period), "j2": 1.08262668e-3, "r_eq": 6378137.0}

CIRCULAR = lpm.KeplerOrbit(a=6878137.0, e=0.0)
MIN_TIME_BASE = {**_orbit_fields(CIRCULAR), "x0": np.zeros(6),
                 "xf": np.array([5.0, 30.0, -3.0, 0.02, 0.5, 0.01]), "thrust": 1.0,
                 "mass": 200.0, "duration_bounds": np.array([0.0, np.inf])}
FUEL_ORBIT = lpm.KeplerOrbit(a=6778137.0, e=0.0)
FUEL_BASE = {**_orbit_fields(FUEL_ORBIT), "x0": np.zeros(6),
             "xf": np.array([0.0, 4000.0, 0.0, 0.0, 0.0, 0.0]),
             "duration": float(FUEL_ORBIT.period), "thrust_max": 0.3, "mass": 50.0,
             "isp": 1000.0}
FUEL_MESH = lpm.segmented_lgr(uniform_breaks(0.0, 1.0, 4), 4)
N_HCW = float(CIRCULAR.mean_motion)
CARE_BASE = {"A": np.asarray(hcw_matrix(1.0)), "B": np.vstack([np.zeros((3, 3)), np.eye(3)]),
             "Q": np.eye(6), "R": np.eye(3)}
R1 = np.array([7000e3, 0.0, 0.0])
LAMBERT_BASE = {"r1": R1, "r2": np.array([0.0, 8000e3, 1000e3]), "tof": 3000.0,
                "mu": 3.986004418e14}
PROPAGATE_BASE = {"state": np.array([7000e3, 0.0, 0.0, 0.0, 7546.0, 100.0]),
                  "duration": 600.0, "mu": 3.986004418e14, "j2": 1.08262668e-3,
                  "r_eq": 6378137.0}


def _min_time(d):
    return lpm.solve(lpm.MinimumTimeTransfer(
        _orbit(d), d["x0"], d["xf"], d["thrust"], d["mass"], d["duration_bounds"]), lpm.lg(8),
        throw=False)


def _fuel(d):
    return lpm.solve(lpm.FuelOptimalTransfer(
        _orbit(d), d["x0"], d["xf"], d["duration"], d["thrust_max"], d["mass"], d["isp"]),
        FUEL_MESH, throw=False)


def _propagate(d):
    state, ok = propagate(d["state"], d["duration"], d["mu"], d["j2"], d["r_eq"])
    return {"state": state, "status": jnp.where(ok, Status.SUCCESS, Status.NONFINITE)}


def _float64(base):
    """Every input as a float64 array: one compiled signature for all examples (Python floats
    would be weakly typed, a different jit cache entry)."""
    return {k: np.asarray(v, np.float64) for k, v in base.items()}


ENTRY_POINTS = {name: (_float64(base), call) for name, (base, call) in {
    "stm": (TRANSFER_BASE, lambda d: lpm.solve(_transfer("linear")(d), lpm.lgl(9),
                                               method="stm", throw=False)),
    "kkt": (TRANSFER_BASE, lambda d: lpm.solve(_transfer("linear")(d), lpm.lgl(9),
                                               method="kkt", throw=False)),
    "newton-two-body": (TRANSFER_BASE,
                        lambda d: lpm.solve(_transfer("two-body")(d), lpm.lgl(9),
                                            method="newton", throw=False)),
    "min-time": (MIN_TIME_BASE, _min_time),
    "fuel-optimal": (FUEL_BASE, _fuel),
    "lambert": (LAMBERT_BASE, lambda d: lambert(d["r1"], d["r2"], d["tof"], mu=d["mu"])),
    "care": (CARE_BASE, lambda d: lpm.care(d["A"], d["B"], d["Q"], d["R"])),
    "propagate": (PROPAGATE_BASE, _propagate),
}.items()}


OK_ONLY = {"propagate"}      # returns (state, ok): a failed member is just not ok


# ---- strategies -------------------------------------------------------------------------------

SPECIAL = [np.nan, np.inf, -np.inf, 0.0, -0.0, -1.0, 1e-300, 1e300, -1e300, 0.5]
FLOATS = st.one_of(st.sampled_from(SPECIAL), st.floats(allow_nan=True, allow_infinity=True))


def _scaled(base):
    """Floats around the base value (a valid-looking perturbation) or wild ones."""
    return st.one_of(FLOATS, st.floats(0.0, 3.0).map(lambda s: s * base))


def traced_value(base):
    """A value with the base's shape and dtype (float64): what a vmapped member can be."""
    base = np.asarray(base, dtype=np.float64)
    if base.shape == ():
        return _scaled(float(base)).map(np.float64)
    idx = st.integers(0, base.size - 1)
    return st.tuples(idx, _scaled(float(np.max(np.abs(base))) or 1.0)).map(
        lambda t: np.where(np.arange(base.size) == t[0], t[1], base.ravel()).reshape(
            base.shape))


def concrete_value(base):
    """Anything a user may pass: the traced values, plus wrong shapes, dtypes and types."""
    base_arr = np.asarray(base, dtype=np.float64)
    shapes = [(), (2,), (base_arr.size + 1,), (3, 3)]
    wrong_shape = st.sampled_from([s for s in shapes if s != base_arr.shape]).map(
        lambda s: np.full(s, float(base_arr.ravel()[0]) if base_arr.size else 1.0))
    odd = st.sampled_from([None, "abc", 1 + 2j, True, [1.0, "x"], {"a": 1}])
    as_ints = st.just(np.round(base_arr).astype(np.int64))
    as_list = st.just(base_arr.tolist())
    return st.one_of(traced_value(base), wrong_shape, odd, as_ints, as_list,
                     st.just(base_arr.astype(np.complex128) * (1 + 1j)))


def perturbations(base, value):
    """A dict of 1 or 2 fields of `base` replaced by `value(base[field])` draws."""
    names = sorted(base)
    return st.lists(st.sampled_from(names), min_size=1, max_size=2, unique=True).flatmap(
        lambda chosen: st.fixed_dictionaries({n: value(base[n]) for n in chosen}))


# ---- the checks ------------------------------------------------------------------------------

def _status(out):
    return np.asarray(out["status"] if isinstance(out, dict) else out.status)


def _float_leaves(out):
    """The result's floating-point outputs (not the `problem` it carries: its inputs, where
    inf is a legal bound)."""
    leaves = jax.tree_util.tree_leaves_with_path(out)
    return [np.asarray(x) for path, x in leaves
            if getattr(path[0], "name", None) != "problem"
            and jnp.issubdtype(jnp.asarray(x).dtype, jnp.inexact)]


def _member(out, i):
    return jax.tree_util.tree_map(lambda x: np.asarray(x)[i], out)


def check_result(out):
    """A status from the known codes; everything finite when it says SUCCESS."""
    status = _status(out)
    assert status.shape == ()
    assert int(status) in STATUS_CODES
    if int(status) == Status.SUCCESS:
        for leaf in _float_leaves(out):
            assert np.all(np.isfinite(leaf)), "non-finite output with status SUCCESS"


def run_concrete(call, inputs, changed):
    """(raised?, result). ValueError must name a field that was changed."""
    try:
        out = call(inputs)
    except ValueError as err:
        message = str(err)
        names = {n for c in changed for n in (c, c.split(".")[0], c.split(".")[-1])}
        assert any(n in message for n in names), f"ValueError names none of {changed}: {err}"
        return True, None
    check_result(out)
    return False, out


_BATCHED = {}


def batched(name):
    """jit(vmap(call)) over the flat input dict, compiled once per entry point."""
    if name not in _BATCHED:
        _BATCHED[name] = jax.jit(jax.vmap(ENTRY_POINTS[name][1]))
    return _BATCHED[name]


@pytest.fixture(scope="module")
def base_results():
    """Each entry point's result on its valid base input (concrete): must be SUCCESS."""
    out = {}
    for name, (base, call) in ENTRY_POINTS.items():
        with watchdog():
            out[name] = call(base)
        assert int(_status(out[name])) == Status.SUCCESS, name
    return out


@pytest.mark.parametrize("name", sorted(ENTRY_POINTS))
def test_concrete_bad_input_raises_value_error_or_returns_a_status(name, base_results):
    base, call = ENTRY_POINTS[name]

    @SETTINGS
    @given(perturbations(base, concrete_value))
    def prop(changes):
        with watchdog():
            run_concrete(call, {**base, **changes}, sorted(changes))

    prop()


@pytest.mark.parametrize("name", sorted(ENTRY_POINTS))
def test_traced_bad_input_returns_a_status(name, base_results):
    base, call = ENTRY_POINTS[name]
    f = batched(name)

    @SETTINGS
    @given(perturbations(base, traced_value))
    def prop(changes):
        bad = {**base, **changes}
        stacked = {k: jnp.stack([jnp.asarray(base[k], jnp.float64),
                                 jnp.asarray(bad[k], jnp.float64)]) for k in base}
        with watchdog():
            out = jax.block_until_ready(f(stacked))
            raised, _ = run_concrete(call, {k: np.asarray(v, np.float64) for k, v in bad.items()},
                                     sorted(changes))
        status = _status(out)
        assert status.shape == (2,)
        assert int(status[0]) == Status.SUCCESS, "the valid member of the batch failed"
        for i in range(2):
            check_result(_member(out, i))
        if raised:      # the same checks, traced: INVALID_INPUT (propagate has only `ok`)
            expected = ({s for s in STATUS_CODES if s != Status.SUCCESS} if name in OK_ONLY
                        else {Status.INVALID_INPUT})
            assert int(status[1]) in expected, (
                f"concrete input raised but the traced member says {Status(int(status[1])).name}")

    prop()
