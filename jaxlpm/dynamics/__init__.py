"""Relative dynamics: linear (HCW, elliptic LVLH, Tschauner-Hempel, Yamanaka-Ankersen STM) and
nonlinear (two-body + J2 gravity; relative motion, inertial or in LVLH, without linearisation)."""

from .gravity import (gravity_acceleration, gravity_acceleration_difference, inertial_rhs,
                      j2_acceleration, j2_potential, two_body_acceleration)
from .nonlinear import (lvlh_frame_motion, relative_inertial_rhs, relative_lvlh_acceleration,
                        relative_lvlh_rhs)
from .linear import (chief_polar_rates, elliptic_lvlh_matrix, elliptic_lvlh_rhs, hcw_drift,
                     hcw_flow, hcw_matrix, hcw_rhs,
                     tschauner_hempel_drift, tschauner_hempel_input_gain,
                     tschauner_hempel_matrix, tschauner_hempel_rhs)
from .stm import (ya_inplane_fundamental, ya_inplane_inverse, ya_outofplane_fundamental,
                  yamanaka_ankersen_inplane, yamanaka_ankersen_outofplane, yamanaka_ankersen_stm)

__all__ = [
    "chief_polar_rates", "elliptic_lvlh_matrix", "elliptic_lvlh_rhs", "hcw_drift", "hcw_flow",
    "hcw_matrix", "hcw_rhs",
    "tschauner_hempel_drift", "tschauner_hempel_input_gain", "tschauner_hempel_matrix",
    "tschauner_hempel_rhs",
    "ya_inplane_fundamental", "ya_inplane_inverse", "ya_outofplane_fundamental",
    "yamanaka_ankersen_inplane",
    "yamanaka_ankersen_outofplane", "yamanaka_ankersen_stm",
    "gravity_acceleration", "gravity_acceleration_difference", "inertial_rhs", "j2_acceleration",
    "j2_potential", "two_body_acceleration", "relative_inertial_rhs", "relative_lvlh_rhs",
    "lvlh_frame_motion", "relative_lvlh_acceleration",
]
