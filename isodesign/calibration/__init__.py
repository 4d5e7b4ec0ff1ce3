"""Calibration from measurements: the diaphragm and the air side of a spring from rig data.

* :mod:`~isodesign.calibration.data`: measured complex stiffness, the CSV schema and reader.
* :mod:`~isodesign.calibration.diaphragm_fit`: diaphragm identification (convex, cvxpy).
* :mod:`~isodesign.calibration.air_fit`: K, D_c and n by nonlinear least squares (CasADi).
"""

from isodesign.calibration.data import CONFIGURATIONS, MeasuredStiffness, read_measured_csv
from isodesign.calibration.diaphragm_fit import DiaphragmFit, air_share, fit_diaphragm

__all__ = [
    "CONFIGURATIONS",
    "DiaphragmFit",
    "MeasuredStiffness",
    "air_share",
    "fit_diaphragm",
    "read_measured_csv",
]
