"""Relative dynamics: linear (HCW, elliptic LVLH, Tschauner-Hempel, Yamanaka-Ankersen STM) and
nonlinear two-body relative motion."""

from .nonlinear import relative_two_body_rhs, two_body_acceleration
from .linear import (chief_polar_rates, elliptic_lvlh_matrix, elliptic_lvlh_rhs, hcw_matrix,
                     hcw_rhs, tschauner_hempel_input_gain, tschauner_hempel_matrix,
                     tschauner_hempel_rhs)
from .stm import (ya_inplane_fundamental, ya_inplane_inverse, ya_outofplane_fundamental,
                  yamanaka_ankersen_inplane, yamanaka_ankersen_outofplane, yamanaka_ankersen_stm)

__all__ = [
    "chief_polar_rates", "elliptic_lvlh_matrix", "elliptic_lvlh_rhs", "hcw_matrix", "hcw_rhs",
    "tschauner_hempel_input_gain", "tschauner_hempel_matrix", "tschauner_hempel_rhs",
    "ya_inplane_fundamental", "ya_inplane_inverse", "ya_outofplane_fundamental",
    "yamanaka_ankersen_inplane",
    "yamanaka_ankersen_outofplane", "yamanaka_ankersen_stm", "relative_two_body_rhs",
    "two_body_acceleration",
]
