"""Orbits and frames: Keplerian elements, time <-> true anomaly, inertial <-> LVLH <-> TH."""

from .frames import (inertial_to_lvlh, lvlh_angular_velocity, lvlh_basis, lvlh_to_relative_inertial, lvlh_to_th,
                     relative_inertial_to_lvlh, th_to_lvlh)
from .kepler import (KeplerOrbit, eccentric_from_mean, eccentric_from_true, elements_to_state,
                     mean_from_true, state_to_elements, time_from_true_anomaly,
                     true_anomaly_from_time, true_from_eccentric)

__all__ = [
    "KeplerOrbit", "eccentric_from_mean", "eccentric_from_true", "elements_to_state",
    "mean_from_true", "state_to_elements", "time_from_true_anomaly", "true_anomaly_from_time",
    "true_from_eccentric", "inertial_to_lvlh", "lvlh_angular_velocity", "lvlh_basis", "lvlh_to_relative_inertial",
    "lvlh_to_th", "relative_inertial_to_lvlh", "th_to_lvlh",
]
