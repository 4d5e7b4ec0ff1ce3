"""Band-by-band compliance of band RMS velocities with a criterion curve."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from isodesign.errors import InputError, check_finite_array
from isodesign.floor.bands import (
    Bands,
)
from isodesign.floor.curves import CriterionCurve, criterion
from isodesign.floor.spectrum import _readonly
from isodesign.results import ResultDisplay

__all__ = [
    "Compliance",
    "compliance",
]


@dataclass(frozen=True, eq=False, repr=False)
class Compliance(ResultDisplay):
    """Band-by-band comparison of band RMS velocities with a criterion curve.

    Attributes
    ----------
    criterion : str
    bands : Bands
    velocity_rms_m_s : numpy.ndarray
    limit_velocity_rms_m_s : numpy.ndarray
    """

    criterion: str
    bands: Bands
    velocity_rms_m_s: np.ndarray
    limit_velocity_rms_m_s: np.ndarray

    @property
    def ratio(self) -> np.ndarray:
        """Band RMS velocity / limit, per band (<= 1 complies)."""
        return self.velocity_rms_m_s / self.limit_velocity_rms_m_s

    @property
    def passes(self) -> bool:
        """True when every band is at or below the limit."""
        return bool(np.all(self.ratio <= 1.0))

    @property
    def worst_ratio(self) -> float:
        """Largest ratio over the bands."""
        return float(np.max(self.ratio))

    @property
    def worst_band_hz(self) -> float:
        """Nominal centre of the band with the largest ratio (Hz)."""
        return float(self.bands.nominal_hz[int(np.argmax(self.ratio))])

    def _summary_items(self) -> list[tuple[str, str]]:
        """Verdict, worst band and ratio (for repr and notebooks)."""
        return [("", "PASS" if self.passes else "FAIL"), ("criterion", self.criterion),
                ("worst band", f"{self.worst_band_hz:g} Hz, ratio {self.worst_ratio:.3g}"),
                ("bands", str(len(self.bands)))]

    def to_frame(self):
        """DataFrame: band columns, velocity, limit, ratio, pass."""
        df = self.bands.to_frame()
        df.insert(0, "criterion", self.criterion)
        df["velocity_rms_m_s"] = self.velocity_rms_m_s
        df["limit_velocity_rms_m_s"] = self.limit_velocity_rms_m_s
        df["ratio"] = self.ratio
        df["pass"] = self.ratio <= 1.0
        return df


def compliance(velocity_rms_m_s, bands: Bands, curve: str | CriterionCurve) -> Compliance:
    """Compare band RMS velocities (m/s) with a criterion, band by band.

    Parameters
    ----------
    velocity_rms_m_s : array_like
        One band RMS velocity per band, >= 0.
    bands : Bands
    curve : str or CriterionCurve

    Returns
    -------
    Compliance
    """
    c = criterion(curve)
    if not isinstance(bands, Bands):
        raise InputError(f"bands: expected Bands, got {type(bands).__name__}")
    v = check_finite_array("velocity_rms_m_s", velocity_rms_m_s, positive=False)
    if v.shape != (len(bands),) or np.any(v < 0):
        raise InputError(
            f"velocity_rms_m_s: expected {len(bands)} values >= 0 (one per band), got {v!r}"
        )
    return Compliance(c.name, bands, _readonly(v), _readonly(c.velocity_rms_m_s(bands)))
