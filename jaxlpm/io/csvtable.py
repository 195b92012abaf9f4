"""`to_csv(solution, path, times=None)`: one solution's trajectory as a CSV table, in SI.

Columns: t_s (s since the start of the transfer), x_m, y_m, z_m (m), vx_m_s, vy_m_s, vz_m_s
(m/s), ux_m_s2, uy_m_s2, uz_m_s2 (the thrust acceleration, m/s^2) and u_norm_m_s2 (|u|), in
the solution's frame: LVLH for the relative transfers (origin at the chief, x radial outward,
y along-track, z along the orbit normal; velocities relative to the rotating frame), the
Earth-centred inertial frame for the intercepts. Three lines starting with "#" before the
column names say what was solved, the frame and the units; values are written with 17
significant digits (float64 read back exactly). `pandas.read_csv(path, comment="#")` or
`numpy.genfromtxt(path, delimiter=",", skip_header=3, names=True)` read it.
"""

from pathlib import Path

import jax.numpy as jnp
import numpy as np

from ..status import Status
from .sampling import evaluate, sample_times, single

COLUMNS = ("t_s", "x_m", "y_m", "z_m", "vx_m_s", "vy_m_s", "vz_m_s", "ux_m_s2", "uy_m_s2",
           "uz_m_s2", "u_norm_m_s2")
FRAMES = {
    "LVLH": ("LVLH, origin at the chief: x radial outward, y along-track, z along the orbit "
             "normal; velocities relative to the rotating frame"),
    "inertial": "Earth-centred inertial (equatorial: z along the Earth's rotation axis)",
}


def to_csv(solution, path, times=None) -> Path:
    """Write one solution's states, controls and |u| at `times` (s since the start; default
    `jaxlpm.io.sampling.sample_times`: 201 uniform times) to the CSV file `path` (module
    docstring) and return the path. ValueError for a batch or bad times."""
    single(solution, "to_csv")
    if solution.frame not in FRAMES:
        raise ValueError(f"solution.frame must be one of {tuple(FRAMES)}, got "
                         f"{solution.frame!r}")
    t = sample_times(solution, times)
    states, controls = (np.asarray(x) for x in evaluate(solution, jnp.asarray(t)))
    table = np.column_stack([t, states, controls, np.linalg.norm(controls, axis=1)])
    path = Path(path)
    with open(path, "w") as fh:
        fh.write(f"# {type(solution.problem).__name__} solved by {solution.method!r}, status "
                 f"{Status(int(np.asarray(solution.status))).name}\n")
        fh.write(f"# frame: {FRAMES[solution.frame]}\n")
        fh.write("# units: SI: t in s since the start of the transfer; x, y, z in m; vx, vy, "
                 "vz in m/s; ux, uy, uz, u_norm (thrust acceleration, |u|) in m/s^2\n")
        fh.write(",".join(COLUMNS) + "\n")
        np.savetxt(fh, table, delimiter=",", fmt="%.17g")
    return path
