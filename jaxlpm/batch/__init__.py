"""Batches of problems: sweeps (chunked, sharded, resumable), random problem families
(dispersions), Monte Carlo and sensitivity studies."""

from .dispersion import dispersion_parameters, mei2010_dispersion
from .montecarlo import (ExecutionErrors, execution_draws, execution_monte_carlo,
                         replan_monte_carlo)
from .sweep import (ChunkStore, Family, SweepResult, converged_statistics,
                    load_sweep, parameter_grid, save_npz_atomic, sensitivity_family, sweep,
                    transfer_builder, transfer_family, transfer_record, write_json_atomic)

__all__ = ["ChunkStore", "ExecutionErrors", "Family", "SweepResult", "converged_statistics", "dispersion_parameters", "execution_draws", "execution_monte_carlo",
           "load_sweep", "mei2010_dispersion", "parameter_grid", "replan_monte_carlo",
           "save_npz_atomic", "sensitivity_family", "sweep", "transfer_builder",
           "transfer_family", "transfer_record", "write_json_atomic"]
