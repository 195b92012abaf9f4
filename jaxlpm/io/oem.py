"""`write_oem(solution, path, epoch=None, ...)`: a CCSDS Orbit Ephemeris Message (OEM 2.0, KVN
text; CCSDS 502.0-B-2, Orbit Data Messages, 2009) of one spacecraft of a solution.

One file holds one spacecraft (the standard's OEM describes a single object; its segments
are successive spans of it): the deputy (the default), or the chief with
spacecraft="chief" in a second file. Header: CCSDS_OEM_VERS = 2.0, CREATION_DATE (UTC, now),
ORIGINATOR; COMMENT lines on where the states come from. Metadata: OBJECT_NAME, OBJECT_ID,
CENTER_NAME = EARTH, REF_FRAME (an inertial frame the user names, EME2000 by default: the
chief's elements i, raan, argp are taken as given in it), TIME_SYSTEM = UTC, START_TIME,
STOP_TIME. Data: one line per time, "epoch x y z vx vy vz" in km and km/s (the standard's
units) with 17 significant digits; no covariance.

States: `jaxlpm.io.inertial.inertial_states` (the solution's own model; the J2 chief for
the "j2" model). Epochs: epoch + t, t the solution's time (s since its start) rounded to the
microsecond, and the state is evaluated at the rounded time, so every line is exact for the
epoch it names. UTC is counted by calendar arithmetic: a leap second inside the span is not
inserted.
"""

from datetime import datetime, timedelta, timezone
from pathlib import Path

import numpy as np

from ..orbits.epoch import utc_datetime
from ..status import Status
from .inertial import SPACECRAFT, inertial_states
from .sampling import sample_times, single

VERSION = "2.0"
INERTIAL_FRAMES = ("EME2000", "GCRF", "ICRF", "MOD", "TEME", "TOD")
"""The REF_FRAME values `write_oem` accepts: Earth-centred inertial frames by their CCSDS names."""
MICROSECONDS = 1e6                  # per second


def _problem_epoch(problem):
    """The epoch a problem carries (`orbit.epoch`, an intercept's `epoch`), or None."""
    holder = getattr(problem, "intercept", problem)
    holder = getattr(holder, "orbit", holder)
    return getattr(holder, "epoch", None)


def _name(value, what: str) -> str:
    if not isinstance(value, str) or not value.strip() or "\n" in value or "=" in value:
        raise ValueError(f"{what} must be a non-empty one-line string without '=', got "
                         f"{value!r:.80}")
    return value.strip()


def _stamp(t: datetime) -> str:
    return t.strftime("%Y-%m-%dT%H:%M:%S.%f")


def _microseconds(solution, times) -> np.ndarray:
    """The times (s) rounded to whole microseconds since the start, within [0, duration],
    strictly increasing (OEM epochs); ValueError otherwise."""
    t = sample_times(solution, times)
    last = np.floor(float(np.asarray(solution.duration)) * MICROSECONDS)
    micro = np.clip(np.round(t * MICROSECONDS), 0.0, last).astype(np.int64)
    if np.any(np.diff(micro) <= 0):
        raise ValueError("times must be strictly increasing and at least 1 microsecond apart "
                         "(OEM epochs)")
    return micro


def write_oem(solution, path, epoch=None, times=None, *, ref_frame: str = "EME2000",
              spacecraft: str = "deputy", object_name: str | None = None,
              object_id: str | None = None, originator: str = "jaxlpm") -> Path:
    """Write the CCSDS OEM of one solution's `spacecraft` ("deputy" or "chief") to `path`
    and return the path (module docstring).

    epoch        the UTC date and time of t = 0 (a datetime, naive meaning UTC, or an ISO
                 8601 string); None: the problem's own (`KeplerOrbit.epoch`, or an
                 intercept's `epoch`)
    times        s since the start (increasing, >= 1 microsecond apart); default
                 `jaxlpm.io.sampling.sample_times` (201 uniform times)
    ref_frame    the inertial frame the chief's elements are given in, one of
                 INERTIAL_FRAMES; an intercept's states are taken as given in it
    object_name  OBJECT_NAME (default "DEPUTY" or "CHIEF"); object_id OBJECT_ID (default
                 the name; the standard recommends the international designator)
    ValueError for a batch, bad times, epoch, frame, names or spacecraft (an intercept has
    no chief); RuntimeError if the J2 chief's integration fails.
    """
    single(solution, "write_oem")
    epoch = _problem_epoch(solution.problem) if epoch is None else epoch
    if epoch is None:
        raise ValueError("write_oem needs an epoch: pass epoch= (UTC at t = 0) or give the "
                         "problem one (KeplerOrbit(..., epoch=...), or the intercept's)")
    start = utc_datetime(epoch)
    if ref_frame not in INERTIAL_FRAMES:
        raise ValueError(f"ref_frame must be an Earth-centred inertial frame, one of "
                         f"{INERTIAL_FRAMES}, got {ref_frame!r}")
    if spacecraft not in SPACECRAFT:
        raise ValueError(f"spacecraft must be one of {SPACECRAFT}, got {spacecraft!r}")
    name = _name(spacecraft.upper() if object_name is None else object_name, "object_name")
    ident = _name(name if object_id is None else object_id, "object_id")
    originator = _name(originator, "originator")
    micro = _microseconds(solution, times)
    t = np.minimum(micro / MICROSECONDS, float(np.asarray(solution.duration)))
    states = inertial_states(solution, t, spacecraft) / 1e3                     # km, km/s
    epochs = [_stamp(start + timedelta(microseconds=int(m))) for m in micro]

    problem = solution.problem
    if solution.frame == "inertial":
        source = f"the spacecraft's own states (frame inertial), taken as given in {ref_frame}"
    else:
        model = getattr(problem, "model", "linear")
        chief = ("two-body + J2 chief osculating problem.orbit at the epoch" if model == "j2"
                 else "Keplerian chief on problem.orbit")
        source = (f"{chief} (elements i, raan, argp as given in {ref_frame})"
                  + ("" if spacecraft == "chief" else " plus the solution's LVLH state"))
    lines = [
        f"CCSDS_OEM_VERS = {VERSION}",
        f"COMMENT {type(problem).__name__} solved by {solution.method!r}, status "
        f"{Status(int(np.asarray(solution.status))).name}",
        f"COMMENT states: {source}",
        "COMMENT epochs: the given epoch + the solution's time (no leap second inserted)",
        f"CREATION_DATE = {_stamp(datetime.now(timezone.utc).replace(tzinfo=None))}",
        f"ORIGINATOR = {originator}",
        "",
        "META_START",
        f"OBJECT_NAME = {name}",
        f"OBJECT_ID = {ident}",
        "CENTER_NAME = EARTH",
        f"REF_FRAME = {ref_frame}",
        "TIME_SYSTEM = UTC",
        f"START_TIME = {epochs[0]}",
        f"STOP_TIME = {epochs[-1]}",
        "META_STOP",
        "",
        *(f"{stamp} " + " ".join(f"{v:.16e}" for v in row)
          for stamp, row in zip(epochs, states)),
    ]
    path = Path(path)
    path.write_text("\n".join(lines) + "\n")
    return path
