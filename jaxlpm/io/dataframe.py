"""Sweep and Monte Carlo results as flat columns (`columns`), and as a pandas DataFrame
(`to_dataframe`) when pandas is installed: jaxlpm does not depend on it.

One row per member or sample, from
  a `SweepResult` (`jaxlpm.batch.sweep`, `load_sweep`, `replan_monte_carlo`): the tables of
      every point count one after the other (their "points" column tells them apart);
  an `execution_monte_carlo` dict: its per-sample arrays, those with the leading length of
      its `status` (the draws, final_state, the misses), not the nominal flight's
      ("nominal", "nominal_final_state"), the model or the statistics;
  any dict of arrays with a common leading length (the rows).
A column with more axes becomes one column per entry: "final_state[0]" ... "final_state[5]"
for (n, 6), "name[i,j]" for (n, a, b). Values and units are the result's own (SI).
"""

from collections.abc import Mapping

import jax
import numpy as np

NOMINAL = ("nominal", "nominal_final_state")


def _flat(name: str, values: np.ndarray, out: dict) -> None:
    if values.ndim == 1:
        out[name] = values
        return
    flat = values.reshape(values.shape[0], -1)
    for j, idx in enumerate(np.ndindex(values.shape[1:])):
        out[f"{name}[{','.join(map(str, idx))}]"] = flat[:, j]


def _table(table: Mapping) -> dict:
    """The flat columns of one dict of per-row arrays (module docstring)."""
    arrays = {k: np.asarray(v) for k, v in table.items()
              if isinstance(v, (np.ndarray, jax.Array)) and np.ndim(v) >= 1 and k not in NOMINAL}
    if "status" in arrays:
        rows = len(arrays["status"])
        arrays = {k: v for k, v in arrays.items() if v.shape[0] == rows}
    elif len({v.shape[0] for v in arrays.values()}) > 1:
        shapes = {k: v.shape for k, v in arrays.items()}
        raise ValueError(f"a table's arrays need a common leading length (the rows), got "
                         f"{shapes}")
    out = {}
    for name, values in arrays.items():
        _flat(str(name), values, out)
    return out


def columns(result) -> dict:
    """{column name: 1-D NumPy array}, one row per member (module docstring); ValueError for
    anything else."""
    tables = getattr(result, "tables", None)
    if isinstance(tables, Mapping):
        parts = [_table(t) for _, t in sorted(tables.items())]
        if any(p.keys() != parts[0].keys() for p in parts):
            raise ValueError("the tables of a SweepResult need the same columns")
        return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]} if parts else {}
    if isinstance(result, Mapping):
        return _table(result)
    raise ValueError(f"columns takes a SweepResult or a dict of per-member arrays (an "
                     f"execution Monte Carlo's), got a {type(result).__name__}")


def to_dataframe(result):
    """`columns(result)` as a pandas.DataFrame; ImportError if pandas is not installed."""
    try:
        import pandas
    except ImportError:
        raise ImportError("to_dataframe needs pandas (pip install pandas), which jaxlpm does "
                          "not depend on; columns(result) gives the same columns as NumPy "
                          "arrays") from None
    return pandas.DataFrame(columns(result))
