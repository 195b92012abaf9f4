"""Pseudospectral collocation: Legendre-Gauss(-Lobatto/-Radau) grids and barycentric operators."""

from .barycentric import (
    barycentric_interpolate,
    barycentric_weights,
    differentiation_matrix,
    integration_matrix,
    interpolation_matrix,
)
from .grid import Grid, lg, lgl, lgr, make_grid
from .legendre import lg_nodes_weights, lgl_nodes_weights, lgr_nodes_weights

__all__ = [
    "Grid",
    "barycentric_interpolate",
    "barycentric_weights",
    "differentiation_matrix",
    "integration_matrix",
    "interpolation_matrix",
    "lg",
    "lg_nodes_weights",
    "lgl",
    "lgl_nodes_weights",
    "lgr",
    "lgr_nodes_weights",
    "make_grid",
]
