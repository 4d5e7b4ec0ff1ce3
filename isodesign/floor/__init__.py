"""The floor: one-third-octave bands, units, vibration criteria and floor spectra.

One concept a module:

* :mod:`~isodesign.floor.bands`: IEC 61260-1 one-third-octave bands (:class:`Bands`).
* :mod:`~isodesign.floor.units`: quantities, units, band RMS <-> PSD conversions.
* :mod:`~isodesign.floor.curves`: the named criterion curves (VC, ISO-derived, NIST-A).
* :mod:`~isodesign.floor.curve_files`: criterion curves from CSV files.
* :mod:`~isodesign.floor.spectrum`: :class:`FloorSpectrum`, the floor velocity PSD.
* :mod:`~isodesign.floor.compliance`: band-by-band comparison with a criterion.
* :mod:`~isodesign.floor.survey`: floor spectra from survey time histories (Welch, band
  statistics).
"""

from isodesign.floor.bands import RELATIVE_BANDWIDTH, Bands, third_octave_bands
from isodesign.floor.compliance import Compliance, compliance
from isodesign.floor.curve_files import criterion_from_csv
from isodesign.floor.curves import (
    CriterionCurve,
    CurveSegment,
    criteria_table,
    criterion,
    criterion_names,
)
from isodesign.floor.spectrum import FloorSpectrum
from isodesign.floor.survey import (
    SurveyRecord,
    SurveyResult,
    analyze_record,
    floor_from_record,
    read_record,
)
from isodesign.floor.units import (
    QUANTITIES,
    STANDARD_GRAVITY_M_S2,
    band_rms_to_psd,
    convert_band_rms,
    convert_psd,
    psd_to_band_rms,
    unit_factor,
)

__all__ = [
    "QUANTITIES",
    "RELATIVE_BANDWIDTH",
    "STANDARD_GRAVITY_M_S2",
    "Bands",
    "Compliance",
    "CriterionCurve",
    "CurveSegment",
    "FloorSpectrum",
    "SurveyRecord",
    "SurveyResult",
    "analyze_record",
    "band_rms_to_psd",
    "compliance",
    "convert_band_rms",
    "convert_psd",
    "criteria_table",
    "criterion",
    "criterion_from_csv",
    "criterion_names",
    "floor_from_record",
    "psd_to_band_rms",
    "read_record",
    "third_octave_bands",
    "unit_factor",
]
