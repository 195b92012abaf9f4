"""Physical constants in SI units, with their sources.

MU_EARTH : Earth's gravitational parameter, m^3/s^2 (WGS 84, NIMA TR8350.2, 3rd ed., 2000).
R_EARTH  : Earth's equatorial radius, m (WGS 84).
J2_EARTH : Earth's second zonal harmonic, dimensionless (EGM2008 unnormalised C20 = -J2;
           Pavlis et al., JGR 117, B04406, 2012).
G0       : standard gravity, m/s^2 (CGPM 1901, conventional value).
"""

MU_EARTH = 3.986004418e14
R_EARTH = 6378137.0
J2_EARTH = 1.08262668e-3
G0 = 9.80665
