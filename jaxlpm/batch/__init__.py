"""Batches of problems: random problem families (dispersions) for robustness and Monte Carlo."""

from .dispersion import dispersion_parameters, mei2010_dispersion

__all__ = ["dispersion_parameters", "mei2010_dispersion"]
