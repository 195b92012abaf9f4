"""Batches of problems of any family: sweeps over parameter tables (chunked, sharded,
resumable; grid sizes as point counts), Monte Carlo studies (the user's dispersion re-planned;
one plan flown with execution errors) and sensitivities. A paper's own dispersion lives with
its case (`jaxlpm.cases.mei2010.dispersion`)."""

from ..mapping import map_in_groups
from .family import (SweepFamily, problem_table, sensitivity_family, solution_record,
                     solve_member, transfer_builder, transfer_family, transfer_record)
from .montecarlo import (ExecutionErrors, execution_draws, execution_monte_carlo,
                         replan_monte_carlo)
from .refine import Refinement, refine_batch
from .store import ChunkStore, save_npz_atomic, write_json_atomic
from .sweep import SweepResult, converged_statistics, load_sweep, parameter_grid, sweep

__all__ = ["ChunkStore", "ExecutionErrors", "SweepFamily", "SweepResult",
           "converged_statistics", "execution_draws", "execution_monte_carlo", "load_sweep",
           "map_in_groups", "parameter_grid", "problem_table", "Refinement", "refine_batch",
           "replan_monte_carlo",
           "save_npz_atomic", "sensitivity_family", "solution_record", "solve_member", "sweep",
           "transfer_builder", "transfer_family", "transfer_record", "write_json_atomic"]
