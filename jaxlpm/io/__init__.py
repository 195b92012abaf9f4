"""Saving and exporting results (SI units; each function's docstring names frames and units).

`save(result, path)` / `load(path)`: a `Solution` (batched or not), a `SweepResult` or a
Monte Carlo result in one .npz archive with JSON metadata, no pickle, loaded back exactly
(`read_metadata` reads the metadata alone). `to_csv(solution, path, times=None)`: t, the
state, the control and |u| as a CSV table in the solution's frame. `write_oem(solution,
path, epoch=None, ...)`: a CCSDS OEM of the deputy's (or the chief's) inertial ephemeris,
dated by the given epoch or the problem's own;
`inertial_states` gives those states as an array. `columns(result)` / `to_dataframe(result)`:
sweep and Monte Carlo results as flat columns or a pandas DataFrame (pandas optional).
"""

from .archive import SCHEMA_VERSION, load, read_metadata, save
from .csvtable import to_csv
from .dataframe import columns, to_dataframe
from .inertial import inertial_states
from .oem import INERTIAL_FRAMES, write_oem
from .sampling import DEFAULT_SAMPLES, sample_times

__all__ = ["DEFAULT_SAMPLES", "INERTIAL_FRAMES", "SCHEMA_VERSION", "columns",
           "inertial_states", "load", "read_metadata", "sample_times", "save", "to_csv",
           "to_dataframe", "write_oem"]
