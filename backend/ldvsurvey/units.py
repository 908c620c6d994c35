"""Unit conversions, named for the direction they convert in: ``x_rad = x_deg * RAD_PER_DEG``.

Multiply a value in the unit after ``PER`` by the constant to get the unit before it
(``RAD_PER_DEG`` turns degrees into radians). ``DEG_TO_RAD`` etc. are the same numbers under the
other common spelling. Plain floats, so numba-compiled code may use them as globals.
"""

from __future__ import annotations

import math

#: radians per degree: ``angle_rad = angle_deg * RAD_PER_DEG``
RAD_PER_DEG = math.pi / 180.0
#: degrees per radian: ``angle_deg = angle_rad * DEG_PER_RAD``
DEG_PER_RAD = 180.0 / math.pi
DEG_TO_RAD = RAD_PER_DEG
RAD_TO_DEG = DEG_PER_RAD

#: radians per arcsecond (deflections of the vertical, tilt)
RAD_PER_ARCSEC = RAD_PER_DEG / 3600.0
ARCSEC_PER_RAD = 1.0 / RAD_PER_ARCSEC
#: radians per arcminute (grid steps)
RAD_PER_ARCMIN = RAD_PER_DEG / 60.0

#: standard gravity g0 in m/s² (sensor specifications in g, mg, µg)
G0_MPS2 = 9.80665
#: m/s² per mGal (1 mGal = 1e-5 m/s²)
MPS2_PER_MGAL = 1e-5
MGAL_PER_MPS2 = 1e5
#: m/s² per µg (accelerometer bias and noise specifications)
MPS2_PER_UG = 1e-6 * G0_MPS2
UG_PER_MPS2 = 1.0 / MPS2_PER_UG

#: rad/s per °/h (gyro bias specifications): ``bias_rps = bias_dph * RPS_PER_DPH``
RPS_PER_DPH = RAD_PER_DEG / 3600.0
DPH_PER_RPS = 1.0 / RPS_PER_DPH
#: rad/√s per °/√h (gyro angle random walk): ``arw_rad_rts = arw_dprh * RAD_RTS_PER_DPRH``
RAD_RTS_PER_DPRH = RAD_PER_DEG / 60.0

#: parts per million (scale factors): ``scale_error = scale_ppm * PER_PPM``
PER_PPM = 1e-6
PPM_PER_UNIT = 1e6
