"""Floor vibration criteria and floor spectra.

Contents
--------
* Named criterion curves (band RMS velocity in one-third-octave bands): the generic VC curves
  VC-A ... VC-G, the older VC-A / VC-B variants with a constant-acceleration segment
  (``VC-A-legacy``, ``VC-B-legacy``, UNCONFIRMED), ISO-derived building curves and NIST-A.
  Look them up with :func:`criterion`; list them with :func:`criterion_names`.
* User-defined curves from CSV (:func:`criterion_from_csv`).
* Conversions between band RMS and PSD and between displacement, velocity and acceleration.
* :class:`FloorSpectrum`: a one-sided floor velocity PSD, either point-wise (log-log
  interpolated) or piecewise constant per one-third-octave band (a floor built from a curve
  or from measured band RMS values), with exact band integration.
* :func:`compliance`: band-by-band comparison of band RMS velocities with a curve.

Units: SI inside (m, m/s, m/s^2, PSDs in (m/s)^2/Hz); frequencies in Hz.
Only numpy is imported at module level; pandas is imported inside ``to_frame`` and friends.
The band definitions live in :mod:`isodesign.floor.bands` and are re-exported here.
"""

from __future__ import annotations

import csv
import math
import os
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np

from isodesign.errors import InputError, check_choice, check_finite_array, check_positive
from isodesign.floor.bands import (
    BAND_INDEX_MAX,
    BAND_INDEX_MIN,
    RELATIVE_BANDWIDTH,
    Bands,
    band_index_near,
    band_power_weight,
    third_octave_bands,
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
    "band_rms_to_psd",
    "compliance",
    "convert_band_rms",
    "convert_psd",
    "criteria_table",
    "criterion",
    "criterion_from_csv",
    "criterion_names",
    "psd_to_band_rms",
    "third_octave_bands",
    "unit_factor",
]

#: Standard acceleration of gravity (m/s^2), used for limits given in g (ISO 80000-3).
STANDARD_GRAVITY_M_S2 = 9.80665
#: Kinematic quantities, in order of differentiation.
QUANTITIES = ("displacement", "velocity", "acceleration")
_ORDER = {"displacement": 0, "velocity": 1, "acceleration": 2}
_TWO_PI = 2.0 * math.pi
_REL_TOL = 1e-9
_INCH = 0.0254

_UNITS: Mapping[str, Mapping[str, float]] = MappingProxyType(
    {
        "velocity": MappingProxyType(
            {
                "m/s": 1.0,
                "mm/s": 1e-3,
                "um/s": 1e-6,
                "nm/s": 1e-9,
                "in/s": _INCH,
                "mil/s": _INCH * 1e-3,
                "uin/s": _INCH * 1e-6,
            }
        ),
        "displacement": MappingProxyType(
            {
                "m": 1.0,
                "mm": 1e-3,
                "um": 1e-6,
                "nm": 1e-9,
                "in": _INCH,
                "mil": _INCH * 1e-3,
                "uin": _INCH * 1e-6,
            }
        ),
        "acceleration": MappingProxyType(
            {
                "m/s^2": 1.0,
                "mm/s^2": 1e-3,
                "um/s^2": 1e-6,
                "in/s^2": _INCH,
                "g": STANDARD_GRAVITY_M_S2,
                "mg": STANDARD_GRAVITY_M_S2 * 1e-3,
                "ug": STANDARD_GRAVITY_M_S2 * 1e-6,
            }
        ),
    }
)


# --------------------------------------------------------------------------------------------
# Units and conversions
# --------------------------------------------------------------------------------------------


def _norm_unit(unit: str) -> str:
    u = str(unit).strip().lower().replace(" ", "")
    for micro in ("µ", "μ"):
        u = u.replace(micro, "u")
    u = u.replace("²", "^2").replace("**2", "^2")
    u = re.sub(r"/s2$", "/s^2", u)
    u = u.replace("/s2)", "/s^2)")
    return u


def unit_factor(quantity: str, unit: str, *, psd: bool = False) -> float:
    """Factor converting a value in ``unit`` to SI for the given quantity.

    Parameters
    ----------
    quantity : {'displacement', 'velocity', 'acceleration'}
    unit : str
        Amplitude unit, e.g. ``'um/s'``, ``'in/s'``, ``'uin/s'``, ``'nm'``, ``'m/s^2'``,
        ``'g'``, ``'ug'`` (``'µ'`` and ``'u'`` are the same). With ``psd=True`` the PSD form
        ``'(um/s)^2/Hz'`` or ``'g^2/Hz'`` is also accepted.
    psd : bool
        If True, return the factor for a PSD (the square of the amplitude factor).

    Returns
    -------
    float
        SI value = value * factor.
    """
    check_choice("quantity", quantity, QUANTITIES)
    u = _norm_unit(unit)
    if psd:
        m = re.fullmatch(r"\((.+)\)\^2/hz", u) or re.fullmatch(r"(.+)\^2/hz", u)
        if m:
            u = m.group(1)
    table = _UNITS[quantity]
    if u not in table:
        form = " (or its PSD form '(unit)^2/Hz')" if psd else ""
        raise InputError(f"unit: unknown {quantity} unit {unit!r}{form}; valid: {', '.join(table)}")
    f = table[u]
    return f * f if psd else f


def _omega(frequency_hz, name="frequency_hz"):
    f = check_finite_array(name, frequency_hz, unit="Hz")
    return _TWO_PI * f


def _out(x: np.ndarray, like: Any):
    return float(x) if np.ndim(like) == 0 and np.ndim(x) == 0 else x


def convert_psd(psd, frequency_hz, from_quantity: str, to_quantity: str):
    """Convert a one-sided PSD between displacement, velocity and acceleration.

    ``S_x = S_v / w**2``, ``S_a = w**2 S_v``, ``w = 2 pi f`` (exact, point by point).

    Parameters
    ----------
    psd : array_like
        PSD values (SI: m^2/Hz, (m/s)^2/Hz or (m/s^2)^2/Hz), finite and >= 0.
    frequency_hz : array_like
        Frequencies in Hz (> 0), broadcastable with ``psd``.
    from_quantity, to_quantity : {'displacement', 'velocity', 'acceleration'}

    Returns
    -------
    numpy.ndarray or float
    """
    check_choice("from_quantity", from_quantity, QUANTITIES)
    check_choice("to_quantity", to_quantity, QUANTITIES)
    s = check_finite_array("psd", psd, positive=False)
    if np.any(s < 0):
        raise InputError("psd: every value must be >= 0")
    w = _omega(frequency_hz)
    k = 2 * (_ORDER[to_quantity] - _ORDER[from_quantity])
    return _out(s * w**k, psd)


def convert_band_rms(band_rms, centre_hz, from_quantity: str, to_quantity: str):
    """Convert band RMS values between displacement, velocity and acceleration.

    Uses the band's exact (geometric) centre ``w_m = 2 pi f_m``: ``x = v / w_m``,
    ``a = w_m v``. For a velocity PSD flat within the band, the displacement relation is exact
    (because ``f_l f_u = f_m**2``); the acceleration relation underestimates the in-band RMS
    acceleration by the factor ``sqrt((G**(1/3) + 1 + G**(-1/3)) / 3) = 1.0088`` (0.9 %).

    Parameters
    ----------
    band_rms : array_like
        Band RMS values (SI), finite and >= 0.
    centre_hz : array_like
        Band centre frequencies in Hz (> 0), broadcastable with ``band_rms``.
    from_quantity, to_quantity : {'displacement', 'velocity', 'acceleration'}

    Returns
    -------
    numpy.ndarray or float
    """
    check_choice("from_quantity", from_quantity, QUANTITIES)
    check_choice("to_quantity", to_quantity, QUANTITIES)
    r = check_finite_array("band_rms", band_rms, positive=False)
    if np.any(r < 0):
        raise InputError("band_rms: every value must be >= 0")
    w = _omega(centre_hz, "centre_hz")
    k = _ORDER[to_quantity] - _ORDER[from_quantity]
    return _out(r * w**k, band_rms)


def _bandwidth(bandwidth_hz) -> np.ndarray:
    if isinstance(bandwidth_hz, Bands):
        return bandwidth_hz.bandwidth_hz
    return check_finite_array("bandwidth_hz", bandwidth_hz, unit="Hz")


def band_rms_to_psd(band_rms, bandwidth_hz):
    """PSD level flat within each band that carries the band RMS: ``S = V_b**2 / (f_u - f_l)``.

    Parameters
    ----------
    band_rms : array_like
        Band RMS values (any quantity, SI), finite and >= 0.
    bandwidth_hz : array_like or Bands
        Band widths ``f_u - f_l`` in Hz, or a :class:`Bands` (its ``bandwidth_hz`` is used).

    Returns
    -------
    numpy.ndarray or float
        One-sided PSD in (unit)^2/Hz.
    """
    r = check_finite_array("band_rms", band_rms, positive=False)
    if np.any(r < 0):
        raise InputError("band_rms: every value must be >= 0")
    return _out(r * r / _bandwidth(bandwidth_hz), band_rms)


def psd_to_band_rms(psd, bandwidth_hz):
    """Band RMS of a PSD flat within each band: ``V_b = sqrt(S (f_u - f_l))``.

    Parameters
    ----------
    psd : array_like
        One-sided PSD levels (SI), finite and >= 0.
    bandwidth_hz : array_like or Bands
        Band widths in Hz, or a :class:`Bands`.

    Returns
    -------
    numpy.ndarray or float
    """
    s = check_finite_array("psd", psd, positive=False)
    if np.any(s < 0):
        raise InputError("psd: every value must be >= 0")
    return _out(np.sqrt(s * _bandwidth(bandwidth_hz)), psd)


# --------------------------------------------------------------------------------------------
# Criterion curves
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class CurveSegment:
    """A piece of a criterion curve: a constant band RMS ``value`` of ``quantity``.

    Parameters
    ----------
    f_lo_hz, f_hi_hz : float
        Closed range of *nominal* band centres (Hz) the segment applies to.
    quantity : {'displacement', 'velocity', 'acceleration'}
        Quantity held constant on the segment.
    value : float
        Band RMS value in SI (m, m/s or m/s^2).
    """

    f_lo_hz: float
    f_hi_hz: float
    quantity: str
    value: float

    def __post_init__(self):
        lo = check_positive("f_lo_hz", self.f_lo_hz, unit="Hz")
        hi = check_positive("f_hi_hz", self.f_hi_hz, unit="Hz")
        if lo > hi:
            raise InputError(f"f_lo_hz: must be <= f_hi_hz ({hi:g} Hz), got {lo:g} Hz")
        check_choice("quantity", self.quantity, QUANTITIES)
        check_positive("value", self.value)


@dataclass(frozen=True)
class CriterionCurve:
    """A floor vibration criterion: limiting band RMS velocity per one-third-octave band.

    A curve is either a list of :class:`CurveSegment` (named curves) or a table of points
    interpolated log-log (user-defined curves from CSV).

    Parameters
    ----------
    name : str
        Registry name, e.g. ``'VC-A'``.
    description : str
        One-line definition.
    source : str
        Citation (or the CSV file of a user-defined curve).
    quantity : str
        What is limited, in words (e.g. ``'band RMS velocity'``).
    segments : tuple of CurveSegment
        Segments; a band whose nominal centre lies in several (closed) segments, i.e. on a
        boundary, takes the smallest (strictest) of their limits.
    points_frequency_hz, points_value : tuple of float
        Tabulated curve: band-centre frequencies (Hz, strictly increasing) and band RMS values
        of ``points_quantity`` (SI, > 0), interpolated log-log at the bands' exact centres.
    points_quantity : {'displacement', 'velocity', 'acceleration'}
    unconfirmed : bool
        True when the definition could not be checked against the original source.
    note : str
        Caveats (choices made, rounding).

    Notes
    -----
    Values of other quantities are derived at the band's exact centre ``f_m``:
    ``x = v / (2 pi f_m)``, ``a = 2 pi f_m v`` (the usual tabulation convention).
    """

    name: str
    description: str
    source: str
    quantity: str = "band RMS velocity"
    segments: tuple[CurveSegment, ...] = ()
    points_frequency_hz: tuple[float, ...] = ()
    points_value: tuple[float, ...] = ()
    points_quantity: str = "velocity"
    unconfirmed: bool = False
    note: str = ""

    def __post_init__(self):
        object.__setattr__(self, "segments", tuple(self.segments))
        object.__setattr__(
            self, "points_frequency_hz", tuple(float(v) for v in self.points_frequency_hz)
        )
        object.__setattr__(self, "points_value", tuple(float(v) for v in self.points_value))
        if bool(self.segments) == bool(self.points_frequency_hz):
            raise InputError(
                f"segments: criterion {self.name!r} needs either segments or tabulated points "
                "(points_frequency_hz, points_value), not both or neither"
            )
        if self.points_frequency_hz:
            check_choice("points_quantity", self.points_quantity, QUANTITIES)
            f = check_finite_array("points_frequency_hz", self.points_frequency_hz, unit="Hz")
            check_finite_array("points_value", self.points_value)
            if len(self.points_value) != len(f) or len(f) < 2:
                raise InputError(
                    "points_value: needs at least 2 points and as many values as "
                    f"points_frequency_hz ({len(f)}), got {len(self.points_value)}"
                )
            if np.any(np.diff(f) <= 0):
                raise InputError("points_frequency_hz: must be strictly increasing")

    # ---- range -----------------------------------------------------------------------------
    @property
    def f_min_hz(self) -> float:
        """Lowest band centre (nominal for segments, as tabulated for points) covered, Hz."""
        if self.segments:
            return min(s.f_lo_hz for s in self.segments)
        return self.points_frequency_hz[0]

    @property
    def f_max_hz(self) -> float:
        """Highest band centre covered, Hz."""
        if self.segments:
            return max(s.f_hi_hz for s in self.segments)
        return self.points_frequency_hz[-1]

    def covers(self, bands: Bands) -> np.ndarray:
        """Boolean mask: which bands the curve is defined on."""
        if self.segments:
            n = bands.nominal_hz
            mask = np.zeros(len(bands), dtype=bool)
            for s in self.segments:
                mask |= (n >= s.f_lo_hz * (1 - _REL_TOL)) & (n <= s.f_hi_hz * (1 + _REL_TOL))
            return mask
        c = bands.centre_hz
        lo, hi = self.points_frequency_hz[0], self.points_frequency_hz[-1]
        return (c >= lo * (1 - _REL_TOL)) & (c <= hi * (1 + _REL_TOL))

    def bands(self) -> Bands:
        """All one-third-octave bands the curve is defined on."""
        if self.segments:
            return third_octave_bands(self.f_min_hz, self.f_max_hz)
        wide = third_octave_bands(0.01, 1e5)
        sel = tuple(np.asarray(wide.index)[self.covers(wide)].tolist())
        if not sel:
            raise InputError(
                f"criterion: {self.name!r} covers no one-third-octave band centre "
                f"({self.f_min_hz:g} to {self.f_max_hz:g} Hz)"
            )
        return Bands(sel)

    # ---- values ----------------------------------------------------------------------------
    def _resolve(self, bands: Bands | None) -> Bands:
        if bands is None:
            return self.bands()
        if not isinstance(bands, Bands):
            raise InputError(f"bands: expected a Bands object, got {type(bands).__name__}")
        mask = self.covers(bands)
        if not mask.all():
            outside = ", ".join(np.asarray(bands.labels)[~mask])
            what = "the curve" if self.segments else "the data"
            raise InputError(
                f"bands: bands outside {what} of criterion {self.name!r} (defined for band "
                f"centres {self.f_min_hz:g} to {self.f_max_hz:g} Hz): {outside} Hz"
            )
        return bands

    def velocity_rms_m_s(self, bands: Bands | None = None) -> np.ndarray:
        """Limiting band RMS velocity (m/s) in each band.

        Parameters
        ----------
        bands : Bands, optional
            Bands to evaluate (default: every band the curve is defined on).

        Returns
        -------
        numpy.ndarray

        Raises
        ------
        InputError
            If a band lies outside the curve's range.
        """
        b = self._resolve(bands)
        c = b.centre_hz
        w = _TWO_PI * c
        if self.segments:
            n = b.nominal_hz
            out = np.full(len(b), np.inf)
            for s in self.segments:
                inside = (n >= s.f_lo_hz * (1 - _REL_TOL)) & (n <= s.f_hi_hz * (1 + _REL_TOL))
                v = s.value * w ** (1 - _ORDER[s.quantity])
                out = np.where(inside, np.minimum(out, v), out)
            return out
        fp = np.log(np.asarray(self.points_frequency_hz))
        vp = np.log(np.asarray(self.points_value))
        x = np.clip(np.log(c), fp[0], fp[-1])
        q = np.exp(np.interp(x, fp, vp))
        return q * w ** (1 - _ORDER[self.points_quantity])

    def displacement_rms_m(self, bands: Bands | None = None) -> np.ndarray:
        """Limiting band RMS displacement (m): ``v / (2 pi f_m)`` at the exact centre."""
        b = self._resolve(bands)
        return self.velocity_rms_m_s(b) / (_TWO_PI * b.centre_hz)

    def acceleration_rms_m_s2(self, bands: Bands | None = None) -> np.ndarray:
        """Limiting band RMS acceleration (m/s^2): ``2 pi f_m v`` at the exact centre."""
        b = self._resolve(bands)
        return self.velocity_rms_m_s(b) * (_TWO_PI * b.centre_hz)

    def limit(self, bands: Bands | None = None, quantity: str = "velocity") -> np.ndarray:
        """Limiting band RMS of ``quantity`` (SI) in each band."""
        check_choice("quantity", quantity, QUANTITIES)
        return {
            "velocity": self.velocity_rms_m_s,
            "displacement": self.displacement_rms_m,
            "acceleration": self.acceleration_rms_m_s2,
        }[quantity](bands)

    def to_frame(self, bands: Bands | None = None):
        """DataFrame of the curve: band columns plus the limit in SI and um/s, uin/s."""
        b = self._resolve(bands)
        df = b.to_frame()
        v = self.velocity_rms_m_s(b)
        df.insert(0, "criterion", self.name)
        df["velocity_rms_m_s"] = v
        df["velocity_rms_um_s"] = v / 1e-6
        df["velocity_rms_uin_s"] = v / (_INCH * 1e-6)
        df["displacement_rms_m"] = self.displacement_rms_m(b)
        df["acceleration_rms_m_s2"] = self.acceleration_rms_m_s2(b)
        return df


_VC_SOURCE = (
    "Ungar, E.E. and Gordon, C.G. (1983), 'Vibration challenges in microelectronics "
    "manufacturing', Shock and Vibration Bulletin 53(1); Gordon, C.G. (1991), 'Generic criteria "
    "for vibration-sensitive equipment', Proc. SPIE 1619; as tabulated in IEST-RP-CC012 "
    "(Considerations in cleanroom design)"
)
_ISO_SOURCE = (
    "ISO 2631-2:1989 building-vibration base curve with its multiplying factors "
    "(operating theatre 1, residential day 2, office 4, workshop 8), also ISO 10137:2007 Annex C; "
    "as tabulated with the VC curves by Gordon (1991), Proc. SPIE 1619, and in the ASHRAE "
    "Handbook - HVAC Applications (noise and vibration control)"
)
_NIST_SOURCE = (
    "NIST Advanced Measurement Laboratory criterion, as tabulated in Amick, H., Gendreau, M., "
    "Busch, T. and Gordon, C. (2005), 'Evolving criteria for research facilities: vibration', "
    "Proc. SPIE 5933"
)


def _vc(letter: str, um_s: float, uin_s: float) -> CriterionCurve:
    return CriterionCurve(
        name=f"VC-{letter}",
        description=(
            f"Generic vibration criterion VC-{letter}: {um_s:g} um/s ({uin_s:g} uin/s) band RMS "
            "velocity, flat over the one-third-octave bands 1 to 80 Hz"
        ),
        source=_VC_SOURCE,
        segments=(CurveSegment(1.0, 80.0, "velocity", um_s * 1e-6),),
        note=(
            "SI value is the definition; the imperial value is the published nominal one "
            f"({uin_s:g} uin/s = {uin_s * 0.0254:.4g} um/s)"
        ),
    )


def _vc_legacy(letter: str, um_s: float, ug: float) -> CriterionCurve:
    a = ug * 1e-6 * STANDARD_GRAVITY_M_S2
    return CriterionCurve(
        name=f"VC-{letter}-legacy",
        description=(
            f"Older VC-{letter}: constant band RMS acceleration {ug:g} ug for band centres 4 to "
            f"8 Hz, then {um_s:g} um/s band RMS velocity from 8 to 80 Hz (UNCONFIRMED)"
        ),
        source=_VC_SOURCE + "; older form with a constant-acceleration segment (UNCONFIRMED)",
        segments=(
            CurveSegment(4.0, 8.0, "acceleration", a),
            CurveSegment(8.0, 80.0, "velocity", um_s * 1e-6),
        ),
        unconfirmed=True,
        note=(
            f"The two segments meet within 1.5 %: {ug:g} ug/(2 pi 8 Hz) = "
            f"{a / (_TWO_PI * 8) * 1e6:.2f} um/s; the 8 Hz band takes the smaller (velocity) "
            "value. Not defined below the 4 Hz band."
        ),
    )


def _iso(label: str, factor: int, um_s: float) -> CriterionCurve:
    v = um_s * 1e-6
    a = v * _TWO_PI * 8.0
    return CriterionCurve(
        name=f"ISO-{label}",
        description=(
            f"ISO-derived building curve '{label}' (factor {factor} on the ISO base curve): "
            f"{um_s:g} um/s band RMS velocity over 8 to 80 Hz; constant band RMS acceleration "
            f"{a * 1e3:.3g} mm/s^2 (= {um_s:g} um/s at 8 Hz) over 1 to 8 Hz"
        ),
        source=_ISO_SOURCE,
        segments=(
            CurveSegment(1.0, 8.0, "acceleration", a),
            CurveSegment(8.0, 80.0, "velocity", v),
        ),
        note=(
            "Project choice below 8 Hz: constant acceleration 2 pi (8 Hz) v, i.e. the ISO z-axis "
            "4-8 Hz plateau (5.0 mm/s^2 x factor) extended down to 1 Hz; stricter than the ISO "
            "z-axis curve below 4 Hz. The 8 Hz band takes the velocity value."
        ),
    )


def _nist_a() -> CriterionCurve:
    return CriterionCurve(
        name="NIST-A",
        description=(
            "NIST-A: 25 nm band RMS displacement for band centres 1 to 20 Hz, 3.1 um/s "
            "(125 uin/s) band RMS velocity from 20 to 100 Hz"
        ),
        source=_NIST_SOURCE,
        segments=(
            CurveSegment(1.0, 20.0, "displacement", 25e-9),
            CurveSegment(20.0, 100.0, "velocity", 3.1e-6),
        ),
        note=(
            "SI values (25 nm, 3.1 um/s) are used; the imperial 125 uin/s is 3.175 um/s. "
            "The 20 Hz band takes the smaller value (3.1 um/s against 3.13 um/s from 25 nm)."
        ),
    )


_CURVES: tuple[CriterionCurve, ...] = (
    _vc("A", 50.0, 2000),
    _vc("B", 25.0, 1000),
    _vc("C", 12.5, 500),
    _vc("D", 6.25, 250),
    _vc("E", 3.12, 125),
    _vc("F", 1.56, 62.5),
    _vc("G", 0.78, 31.25),
    _vc_legacy("A", 50.0, 260.0),
    _vc_legacy("B", 25.0, 130.0),
    _iso("workshop", 8, 800.0),
    _iso("office", 4, 400.0),
    _iso("residential-day", 2, 200.0),
    _iso("operating-theatre", 1, 100.0),
    _nist_a(),
)


def _key(name: str) -> str:
    return name.strip().casefold().replace("_", "-").replace(" ", "-")


_REGISTRY: Mapping[str, CriterionCurve] = MappingProxyType({_key(c.name): c for c in _CURVES})


def criterion_names() -> tuple[str, ...]:
    """Names of the built-in criterion curves, in registry order."""
    return tuple(c.name for c in _CURVES)


def criterion(name: str | CriterionCurve) -> CriterionCurve:
    """Look up a built-in criterion curve by name (case-insensitive; ``'vc-a'`` works).

    Parameters
    ----------
    name : str or CriterionCurve
        Curve name (see :func:`criterion_names`); a :class:`CriterionCurve` is returned as is.

    Returns
    -------
    CriterionCurve

    Raises
    ------
    InputError
        Unknown name; the message lists the valid names.
    """
    if isinstance(name, CriterionCurve):
        return name
    if not isinstance(name, str) or _key(name) not in _REGISTRY:
        raise InputError(f"criterion: unknown name {name!r}; valid: {', '.join(criterion_names())}")
    return _REGISTRY[_key(name)]


def criteria_table(
    f_min_hz: float = 1.0,
    f_max_hz: float = 80.0,
    *,
    layout: str = "long",
    names: tuple[str, ...] | None = None,
    velocity_unit: str = "m/s",
):
    """Table of the named criterion curves over the bands ``[f_min_hz, f_max_hz]``.

    Parameters
    ----------
    f_min_hz, f_max_hz : float
        Band range (nominal centres, see :func:`third_octave_bands`).
    layout : {'long', 'wide'}
        ``'long'``: one row per (criterion, band), only bands the curve is defined on, columns
        as in :meth:`CriterionCurve.to_frame`. ``'wide'``: one row per band (``label``,
        ``nominal_hz``, ``centre_hz``) and one column per criterion holding the band RMS
        velocity in ``velocity_unit``; NaN where a curve is not defined.
    names : tuple of str, optional
        Curves to include (default: all, in registry order).
    velocity_unit : str
        Unit of the wide table's values (``'m/s'``, ``'um/s'``, ``'uin/s'``, ...); recorded in
        ``DataFrame.attrs['velocity_unit']``.

    Returns
    -------
    pandas.DataFrame
    """
    import pandas as pd

    check_choice("layout", layout, ("long", "wide"))
    factor = unit_factor("velocity", velocity_unit)
    bands = third_octave_bands(f_min_hz, f_max_hz)
    curves = [criterion(n) for n in (names if names is not None else criterion_names())]
    if layout == "long":
        frames = []
        for c in curves:
            mask = c.covers(bands)
            if mask.any():
                sub = Bands(tuple(np.asarray(bands.index)[mask].tolist()))
                frames.append(c.to_frame(sub))
        df = pd.concat(frames, ignore_index=True)
    else:
        df = pd.DataFrame(
            {
                "label": list(bands.labels),
                "nominal_hz": bands.nominal_hz,
                "centre_hz": bands.centre_hz,
            }
        )
        for c in curves:
            col = np.full(len(bands), np.nan)
            mask = c.covers(bands)
            if mask.any():
                sub = Bands(tuple(np.asarray(bands.index)[mask].tolist()))
                col[mask] = c.velocity_rms_m_s(sub) / factor
            df[c.name] = col
    df.attrs["velocity_unit"] = velocity_unit
    return df


# --------------------------------------------------------------------------------------------
# CSV reading
# --------------------------------------------------------------------------------------------

_HEADER_KEYS = ("quantity", "kind", "unit", "name", "description", "source")


def _read_csv(path) -> tuple[dict[str, str], list[str], list[tuple[int, list[str]]], str]:
    """Read a small CSV with '#' comment lines carrying ``key: value`` pairs."""
    if not isinstance(path, str | os.PathLike):
        raise InputError(f"path: expected a file path, got {path!r}")
    p = Path(path)
    where = f"file '{p}'"
    try:
        text = p.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise InputError(f"path: {where} not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"path: cannot read {where}: {exc}") from None
    header: dict[str, str] = {}
    columns: list[str] | None = None
    rows: list[tuple[int, list[str]]] = []
    for lineno, line in enumerate(text.splitlines(), start=1):
        s = line.strip()
        if not s:
            continue
        if s.startswith("#"):
            for part in s.lstrip("#").split(";"):
                if ":" in part:
                    k, v = part.split(":", 1)
                    k = k.strip().lower()
                    if k in _HEADER_KEYS:
                        header[k] = v.strip()
            continue
        fields = [f.strip() for f in next(csv.reader([s]))]
        if columns is None:
            columns = [f.lower() for f in fields]
            continue
        rows.append((lineno, fields))
    if columns is None or not rows:
        raise InputError(f"path: {where} is empty (needs a column header line and data rows)")
    return header, columns, rows, where


def _column(columns: list[str], name: str, where: str, *, what: str = "column") -> int:
    if name not in columns:
        raise InputError(
            f"path: {where} has no {what} '{name}' (found columns: {', '.join(columns)})"
        )
    return columns.index(name)


def _numbers(
    rows: list[tuple[int, list[str]]], ncols: int, col: int, colname: str, where: str
) -> tuple[np.ndarray, list[int]]:
    vals, lines = [], []
    for lineno, fields in rows:
        if len(fields) != ncols:
            raise InputError(
                f"path: {where} line {lineno}: expected {ncols} fields, got {len(fields)}"
            )
        try:
            v = float(fields[col])
        except ValueError:
            raise InputError(
                f"path: {where} line {lineno}, column '{colname}': expected a number, "
                f"got {fields[col]!r}"
            ) from None
        if not math.isfinite(v):
            raise InputError(
                f"path: {where} line {lineno}, column '{colname}': value must be finite, "
                f"got {fields[col]!r}"
            )
        vals.append(v)
        lines.append(lineno)
    return np.array(vals), lines


def _check_frequencies(f: np.ndarray, lines: list[int], where: str) -> None:
    for i, v in enumerate(f):
        if v <= 0:
            raise InputError(
                f"path: {where} line {lines[i]}, column 'frequency_hz': must be > 0 Hz, got {v:g}"
            )
        if i and v <= f[i - 1]:
            raise InputError(
                f"path: {where} line {lines[i]}, column 'frequency_hz': frequencies must be "
                f"strictly increasing, got {v:g} after {f[i - 1]:g}"
            )


def _check_values(v: np.ndarray, lines: list[int], col: str, where: str, strict: bool) -> None:
    for i, x in enumerate(v):
        if x < 0 or (strict and x == 0):
            need = "> 0 (log-log interpolation)" if strict else ">= 0"
            raise InputError(
                f"path: {where} line {lines[i]}, column '{col}': must be {need}, got {x:g}"
            )


def _snap(f: np.ndarray) -> np.ndarray:
    """Replace frequencies within 2 % of a band's exact centre by that exact centre."""
    out = f.copy()
    for i, v in enumerate(f):
        x = band_index_near(v)
        if x is not None:
            out[i] = 10.0 ** (3.0 + x / 10.0)
    return out


_CURVE_COLUMNS = {
    "velocity_rms_m_s": "velocity",
    "displacement_rms_m": "displacement",
    "acceleration_rms_m_s2": "acceleration",
}


def criterion_from_csv(path, name: str | None = None) -> CriterionCurve:
    """Read a user-defined criterion curve from CSV.

    The file has a column ``frequency_hz`` (band centres, Hz, strictly increasing) and exactly
    one of ``velocity_rms_m_s``, ``displacement_rms_m``, ``acceleration_rms_m_s2`` (band RMS,
    SI, > 0). Optional comment lines ``# name: ...; description: ...; source: ...``.
    Frequencies within 2 % of a band's exact centre (so nominal 1.25 or exact 1.2589) are
    taken as that exact centre. The curve is interpolated log-log between the points;
    evaluating it on a band outside the points raises ``InputError`` ("bands outside the
    data").

    Parameters
    ----------
    path : str or os.PathLike
    name : str, optional
        Curve name (default: the header's ``name``, else the file stem).

    Returns
    -------
    CriterionCurve
    """
    header, cols, rows, where = _read_csv(path)
    fcol = _column(cols, "frequency_hz", where)
    present = [c for c in _CURVE_COLUMNS if c in cols]
    if len(present) != 1:
        raise InputError(
            f"path: {where} needs exactly one value column among "
            f"{', '.join(_CURVE_COLUMNS)} (found columns: {', '.join(cols)})"
        )
    vname = present[0]
    vcol = cols.index(vname)
    f, lines = _numbers(rows, len(cols), fcol, "frequency_hz", where)
    v, _ = _numbers(rows, len(cols), vcol, vname, where)
    _check_frequencies(f, lines, where)
    _check_values(v, lines, vname, where, strict=True)
    if len(f) < 2:
        raise InputError(f"path: {where} needs at least 2 data rows, got {len(f)}")
    fs = _snap(f)
    _check_frequencies(fs, lines, where)
    p = Path(path)
    return CriterionCurve(
        name=name or header.get("name") or p.stem,
        description=header.get("description", f"user-defined curve from {p.name}"),
        source=header.get("source", str(p)),
        quantity=f"band RMS {_CURVE_COLUMNS[vname]}",
        points_frequency_hz=tuple(fs.tolist()),
        points_value=tuple(v.tolist()),
        points_quantity=_CURVE_COLUMNS[vname],
    )


# --------------------------------------------------------------------------------------------
# Floor spectrum
# --------------------------------------------------------------------------------------------


def _readonly(a) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.flags.writeable = False
    return a


@dataclass(frozen=True, eq=False)
class FloorSpectrum:
    """One-sided floor velocity PSD.

    Two representations:

    * point-wise (``bands is None``): PSD values at ``frequency_hz`` (strictly increasing,
      at least 2 points, PSD > 0), interpolated log-log in between; defined on
      ``[frequency_hz[0], frequency_hz[-1]]``;
    * band-constant (``bands`` given, contiguous): ``frequency_hz`` are the bands' exact
      centres and the PSD is constant within each band (``psd >= 0``); defined from the lower
      edge of the first band to the upper edge of the last.

    Parameters
    ----------
    frequency_hz : array_like
        Frequencies (Hz).
    psd_velocity_m2_s2_per_hz : array_like
        One-sided velocity PSD, (m/s)^2/Hz.
    bands : Bands, optional
        Makes the spectrum band-constant.
    name, source : str
        Metadata.

    Notes
    -----
    Equality is identity (the fields are arrays).
    """

    frequency_hz: np.ndarray
    psd_velocity_m2_s2_per_hz: np.ndarray
    bands: Bands | None = None
    name: str = ""
    source: str = ""

    def __post_init__(self):
        f = check_finite_array("frequency_hz", self.frequency_hz, unit="Hz")
        s = check_finite_array(
            "psd_velocity_m2_s2_per_hz", self.psd_velocity_m2_s2_per_hz, positive=False
        )
        if f.ndim != 1 or s.shape != f.shape:
            raise InputError(
                "psd_velocity_m2_s2_per_hz: must be 1-D with one value per frequency "
                f"({f.size}), got shape {s.shape}"
            )
        if self.bands is None:
            if f.size < 2:
                raise InputError("frequency_hz: a point-wise spectrum needs at least 2 points")
            if np.any(np.diff(f) <= 0):
                raise InputError("frequency_hz: must be strictly increasing")
            if np.any(s <= 0):
                raise InputError(
                    "psd_velocity_m2_s2_per_hz: every value must be > 0 for a point-wise "
                    "spectrum (log-log interpolation)"
                )
        else:
            if not isinstance(self.bands, Bands):
                raise InputError(f"bands: expected Bands, got {type(self.bands).__name__}")
            if not self.bands.is_contiguous:
                raise InputError("bands: a band-constant spectrum needs consecutive bands")
            if f.size != len(self.bands) or not np.allclose(
                f, self.bands.centre_hz, rtol=1e-9, atol=0
            ):
                raise InputError(
                    "frequency_hz: for a band-constant spectrum it must be the bands' exact "
                    "centres (bands.centre_hz)"
                )
            if np.any(s < 0):
                raise InputError("psd_velocity_m2_s2_per_hz: every value must be >= 0")
        object.__setattr__(self, "frequency_hz", _readonly(f))
        object.__setattr__(self, "psd_velocity_m2_s2_per_hz", _readonly(s))

    # ---- constructors --------------------------------------------------------------------------
    @classmethod
    def from_band_rms(
        cls, bands: Bands, velocity_rms_m_s, *, name: str = "", source: str = ""
    ) -> FloorSpectrum:
        """Band-constant spectrum with the given band RMS velocities (m/s).

        ``S_b = V_b**2 / (f_u - f_l)``, so :meth:`band_rms_velocity` gives ``V_b`` back.
        """
        if not isinstance(bands, Bands):
            raise InputError(f"bands: expected Bands, got {type(bands).__name__}")
        v = check_finite_array("velocity_rms_m_s", velocity_rms_m_s, positive=False)
        if v.shape != (len(bands),):
            raise InputError(
                f"velocity_rms_m_s: expected {len(bands)} values (one per band), got {v.size}"
            )
        if np.any(v < 0):
            raise InputError("velocity_rms_m_s: every value must be >= 0")
        return cls(
            bands.centre_hz, band_rms_to_psd(v, bands), bands=bands, name=name, source=source
        )

    @classmethod
    def from_criterion(
        cls,
        name_or_curve: str | CriterionCurve,
        f_min_hz: float | None = None,
        f_max_hz: float | None = None,
    ) -> FloorSpectrum:
        """The floor that sits exactly on a criterion curve in every band.

        Band-constant PSD ``S_b = V_b**2 / (f_u - f_l)`` with ``V_b`` the curve's band RMS
        velocity, so that :meth:`band_rms_velocity` reproduces the curve exactly.

        Parameters
        ----------
        name_or_curve : str or CriterionCurve
        f_min_hz, f_max_hz : float, optional
            Band range (nominal centres); default: the curve's own range (1 to 80 Hz for the
            VC and ISO curves, 4 to 80 Hz for the legacy VC curves, 1 to 100 Hz for NIST-A).

        Returns
        -------
        FloorSpectrum
        """
        curve = criterion(name_or_curve)
        if f_min_hz is None and f_max_hz is None:
            bands = curve.bands()
        else:
            own = curve.bands()
            lo = own.nominal_hz[0] if f_min_hz is None else f_min_hz
            hi = own.nominal_hz[-1] if f_max_hz is None else f_max_hz
            bands = third_octave_bands(lo, hi)
        v = curve.velocity_rms_m_s(bands)
        return cls.from_band_rms(bands, v, name=f"{curve.name} floor", source=curve.source)

    @classmethod
    def from_csv(
        cls,
        path,
        quantity: str | None = None,
        kind: str | None = None,
        unit: str | None = None,
        *,
        name: str | None = None,
    ) -> FloorSpectrum:
        """Read a measured floor spectrum from CSV.

        Columns ``frequency_hz`` and ``value``. Comment lines ``# key: value; key: value``
        give ``quantity`` (displacement | velocity | acceleration), ``kind``
        (band_rms | psd), ``unit`` and optionally ``name``; the arguments override the
        header, and a missing one raises ``InputError``.

        * ``kind = band_rms``: one band RMS value per one-third-octave band, rows in
          consecutive bands; ``frequency_hz`` is the band centre, nominal or exact (within
          2 %). Values >= 0. The result is band-constant; displacement/acceleration band RMS
          are turned into the velocity PSD flat in the band that has exactly that band RMS.
        * ``kind = psd``: a one-sided PSD of the quantity (unit given as the amplitude unit,
          e.g. ``um/s``, or as ``(um/s)^2/Hz``), strictly increasing frequencies, values > 0.
          It is converted point by point to a velocity PSD.

        Parameters
        ----------
        path : str or os.PathLike
        quantity, kind, unit : str, optional
        name : str, optional

        Returns
        -------
        FloorSpectrum

        Raises
        ------
        InputError
            Missing/unknown quantity, kind or unit; empty or malformed file; missing column;
            non-numeric, non-finite, negative values; non-monotonic frequency; band_rms rows
            that are not consecutive band centres. The message names the file and line.
        """
        header, cols, rows, where = _read_csv(path)
        opts = {"quantity": quantity, "kind": kind, "unit": unit}
        for key in opts:
            if opts[key] is None:
                opts[key] = header.get(key)
            if opts[key] is None:
                raise InputError(
                    f"{key}: not given as an option and not in the header of {where} "
                    f"(add a comment line '# {key}: ...')"
                )
        q = _norm_unit(opts["quantity"])
        check_choice("quantity", q, QUANTITIES)
        k = _norm_unit(opts["kind"]).replace("-", "_")
        check_choice("kind", k, ("band_rms", "psd"))
        factor = unit_factor(q, opts["unit"], psd=(k == "psd"))
        fcol = _column(cols, "frequency_hz", where)
        vcol = _column(cols, "value", where)
        f, lines = _numbers(rows, len(cols), fcol, "frequency_hz", where)
        v, _ = _numbers(rows, len(cols), vcol, "value", where)
        _check_frequencies(f, lines, where)
        _check_values(v, lines, "value", where, strict=(k == "psd"))
        v = v * factor
        label = name or header.get("name") or Path(path).stem
        src = str(path)
        if k == "psd":
            if len(f) < 2:
                raise InputError(f"path: {where} needs at least 2 data rows for a PSD")
            s = convert_psd(v, f, q, "velocity")
            return cls(f, s, name=label, source=src)
        idx = []
        for i, fi in enumerate(f):
            x = band_index_near(fi)
            if x is None:
                raise InputError(
                    f"path: {where} line {lines[i]}, column 'frequency_hz': {fi:g} Hz is not a "
                    "one-third-octave band centre (nominal or exact, within 2 %)"
                )
            if idx and x != idx[-1] + 1:
                raise InputError(
                    f"path: {where} line {lines[i]}, column 'frequency_hz': band rows must be "
                    f"consecutive one-third-octave bands; {fi:g} Hz does not follow the "
                    f"previous band"
                )
            idx.append(x)
        bands = Bands(tuple(idx))
        s = v * v / band_power_weight(bands, 2 * (_ORDER[q] - 1))
        return cls(bands.centre_hz, s, bands=bands, name=label, source=src)

    # ---- domain ---------------------------------------------------------------------------
    @property
    def kind(self) -> str:
        """``'band_constant'`` or ``'pointwise'``."""
        return "pointwise" if self.bands is None else "band_constant"

    @property
    def f_min_hz(self) -> float:
        """Lowest frequency where the PSD is defined (Hz)."""
        if self.bands is None:
            return float(self.frequency_hz[0])
        return float(self.bands.lower_hz[0])

    @property
    def f_max_hz(self) -> float:
        """Highest frequency where the PSD is defined (Hz)."""
        if self.bands is None:
            return float(self.frequency_hz[-1])
        return float(self.bands.upper_hz[-1])

    def _check_domain(self, f, name="frequency_hz") -> np.ndarray:
        f = check_finite_array(name, f, unit="Hz")
        lo, hi = self.f_min_hz * (1 - _REL_TOL), self.f_max_hz * (1 + _REL_TOL)
        bad = (f < lo) | (f > hi)
        if np.any(bad):
            first = float(np.asarray(f)[bad].flat[0])
            raise InputError(
                f"{name}: {int(bad.sum())} point(s) outside the spectrum's range "
                f"[{self.f_min_hz:g}, {self.f_max_hz:g}] Hz (first: {first:g} Hz)"
            )
        return np.clip(f, self.f_min_hz, self.f_max_hz)

    # ---- evaluation ----------------------------------------------------------------------------
    def psd_velocity(self, frequency_hz):
        """Velocity PSD ((m/s)^2/Hz) at ``frequency_hz``.

        Point-wise spectra: log-log interpolation. Band-constant spectra: the value of the band
        containing the point; a point exactly on an edge shared by two bands takes the upper
        band (the top edge belongs to the last band). To integrate over a band use
        :meth:`psd_velocity_on` with the band number, or :meth:`band_grid`.

        Raises
        ------
        InputError
            Points outside the spectrum's range.
        """
        f = self._check_domain(frequency_hz)
        s = self.psd_velocity_m2_s2_per_hz
        if self.bands is None:
            lf = np.log(self.frequency_hz)
            out = np.exp(np.interp(np.log(f), lf, np.log(s)))
        else:
            edges = np.append(self.bands.lower_hz, self.bands.upper_hz[-1])
            pos = np.clip(np.searchsorted(edges, f, side="right") - 1, 0, len(s) - 1)
            out = s[pos]
        return _out(out, frequency_hz)

    def psd_velocity_on(self, frequency_hz, band_index=None):
        """Velocity PSD at points known to lie in given bands (edges included).

        Parameters
        ----------
        frequency_hz : array_like
            Frequencies (Hz).
        band_index : int or array_like of int, optional
            IEC band number(s) the points belong to, broadcastable with ``frequency_hz``
            (e.g. ``bands.index_array[:, None]`` for a grid of shape (n_bands, n_points)).
            For a band-constant spectrum the result is that band's constant PSD, also at its
            edges; that is what makes band integration exact. Without it, same as
            :meth:`psd_velocity`.

        Raises
        ------
        InputError
            Points outside their band (relative tolerance 1e-9) or bands outside the spectrum.
        """
        if band_index is None:
            return self.psd_velocity(frequency_hz)
        f = self._check_domain(frequency_hz)
        bi = np.asarray(band_index)
        if bi.dtype.kind not in "iu":
            if not np.all(np.isfinite(bi)) or np.any(bi != np.round(bi)):
                raise InputError("band_index: band numbers must be integers")
            bi = bi.astype(int)
        try:
            f, bi = np.broadcast_arrays(f, bi)
        except ValueError:
            raise InputError(
                f"band_index: shape {bi.shape} does not broadcast with frequency_hz {f.shape}"
            ) from None
        lo_e = 10.0 ** (3.0 + (bi - 0.5) / 10.0)
        hi_e = 10.0 ** (3.0 + (bi + 0.5) / 10.0)
        outside = (f < lo_e * (1 - _REL_TOL)) | (f > hi_e * (1 + _REL_TOL))
        if np.any(outside):
            raise InputError(
                f"frequency_hz: {int(outside.sum())} point(s) lie outside the band given by "
                "band_index"
            )
        if self.bands is None:
            return _out(self.psd_velocity(f), frequency_hz)
        first, last = self.bands.index[0], self.bands.index[-1]
        if np.any((bi < first) | (bi > last)):
            raise InputError(
                f"band_index: must be within the spectrum's bands [{first}, {last}] "
                f"({self.bands.labels[0]} to {self.bands.labels[-1]} Hz)"
            )
        return _out(self.psd_velocity_m2_s2_per_hz[bi - first], frequency_hz)

    def psd(self, frequency_hz, quantity: str = "velocity"):
        """PSD of ``quantity`` at ``frequency_hz`` (SI), from the velocity PSD."""
        check_choice("quantity", quantity, QUANTITIES)
        return convert_psd(self.psd_velocity(frequency_hz), frequency_hz, "velocity", quantity)

    def _resolve_bands(self, bands: Bands | None) -> Bands:
        if bands is None:
            if self.bands is not None:
                return self.bands
            lo, hi = self.f_min_hz * (1 - _REL_TOL), self.f_max_hz * (1 + _REL_TOL)
            x = np.arange(BAND_INDEX_MIN, BAND_INDEX_MAX + 1)
            inside = (10.0 ** (3.0 + (x - 0.5) / 10.0) >= lo) & (
                10.0 ** (3.0 + (x + 0.5) / 10.0) <= hi
            )
            if not inside.any():
                raise InputError(
                    f"bands: no whole one-third-octave band lies inside the spectrum's range "
                    f"[{self.f_min_hz:g}, {self.f_max_hz:g}] Hz"
                )
            return Bands(tuple(x[inside].tolist()))
        if not isinstance(bands, Bands):
            raise InputError(f"bands: expected Bands, got {type(bands).__name__}")
        lo, hi = self.f_min_hz * (1 - _REL_TOL), self.f_max_hz * (1 + _REL_TOL)
        bad = (bands.lower_hz < lo) | (bands.upper_hz > hi)
        if np.any(bad):
            raise InputError(
                f"bands: bands outside the data of spectrum {self.name!r} (defined from "
                f"{self.f_min_hz:.4g} to {self.f_max_hz:.4g} Hz): "
                f"{', '.join(np.asarray(bands.labels)[bad])} Hz"
            )
        return bands

    def band_grid(
        self, bands: Bands | None = None, points_per_band: int = 50
    ) -> tuple[np.ndarray, np.ndarray]:
        """Log-spaced frequency grid inside each band and the PSD on it.

        Parameters
        ----------
        bands : Bands, optional
            Default: the spectrum's own bands (band-constant) or every band inside its range.
        points_per_band : int
            Points per band, >= 2, including both edges.

        Returns
        -------
        frequency_hz : numpy.ndarray, shape (n_bands, points_per_band)
            Row ``i`` runs from ``bands.lower_hz[i]`` to ``bands.upper_hz[i]`` (exactly).
        psd_velocity : numpy.ndarray, same shape
            Velocity PSD evaluated band-aware (:meth:`psd_velocity_on`), so a band-constant
            spectrum gives its band's constant on the whole row, edges included.
        """
        b = self._resolve_bands(bands)
        n = _check_points(points_per_band)
        fl, fu = b.lower_hz[:, None], b.upper_hz[:, None]
        t = np.linspace(0.0, 1.0, n)[None, :]
        grid = fl * (fu / fl) ** t
        grid[:, 0], grid[:, -1] = fl[:, 0], fu[:, 0]
        return grid, np.asarray(self.psd_velocity_on(grid, b.index_array[:, None]))

    def band_rms(
        self,
        bands: Bands | None = None,
        quantity: str = "velocity",
        points_per_band: int = 50,
        power_transmissibility: Callable[[np.ndarray], Any] | None = None,
    ) -> np.ndarray:
        """Band RMS of ``quantity``, optionally through a power transmissibility ``|T(f)|^2``.

        ``sqrt(integral over the band of |T(f)|^2 S_q(f) df)`` by the trapezoid rule in ``f``
        on :meth:`band_grid`. For a band-constant spectrum without ``power_transmissibility``
        the band integral is evaluated in closed form (exact); with it, the integrand uses the
        band's own constant PSD at every grid point, edges included, so ``|T| = 1`` gives the
        band RMS to rounding error.

        Parameters
        ----------
        bands : Bands, optional
        quantity : {'displacement', 'velocity', 'acceleration'}
        points_per_band : int
        power_transmissibility : callable, optional
            ``f -> |T(f)|^2`` (vectorized; called with an array of shape
            (n_bands, points_per_band) in Hz; values finite and >= 0).

        Returns
        -------
        numpy.ndarray
            Band RMS in SI, one per band.
        """
        check_choice("quantity", quantity, QUANTITIES)
        b = self._resolve_bands(bands)
        k = 2 * (_ORDER[quantity] - 1)
        if self.bands is not None and power_transmissibility is None:
            s = np.asarray(self.psd_velocity_on(b.centre_hz, b.index_array))
            return np.sqrt(s * band_power_weight(b, k))
        grid, s = self.band_grid(b, points_per_band)
        integrand = s * (_TWO_PI * grid) ** k
        if power_transmissibility is not None:
            w = np.asarray(power_transmissibility(grid), dtype=float)
            try:
                w = np.broadcast_to(w, grid.shape)
            except ValueError:
                raise InputError(
                    f"power_transmissibility: returned shape {w.shape}, expected {grid.shape}"
                ) from None
            if not np.all(np.isfinite(w)) or np.any(w < 0):
                raise InputError(
                    "power_transmissibility: values must be finite and >= 0 (|T(f)|^2)"
                )
            integrand = integrand * w
        return np.sqrt(np.trapezoid(integrand, grid, axis=1))

    def band_rms_velocity(
        self,
        bands: Bands | None = None,
        points_per_band: int = 50,
        power_transmissibility: Callable[[np.ndarray], Any] | None = None,
    ) -> np.ndarray:
        """Band RMS velocity (m/s) per band; see :meth:`band_rms`."""
        return self.band_rms(bands, "velocity", points_per_band, power_transmissibility)

    # ---- output --------------------------------------------------------------------------------
    def to_frame(self):
        """DataFrame of the spectrum.

        Band-constant: band columns (see :meth:`Bands.to_frame`) plus
        ``psd_velocity_m2_s2_per_hz`` and ``velocity_rms_m_s``. Point-wise: ``frequency_hz``
        and ``psd_velocity_m2_s2_per_hz``.
        """
        import pandas as pd

        if self.bands is None:
            return pd.DataFrame(
                {
                    "frequency_hz": self.frequency_hz,
                    "psd_velocity_m2_s2_per_hz": self.psd_velocity_m2_s2_per_hz,
                }
            )
        df = self.bands.to_frame()
        df["psd_velocity_m2_s2_per_hz"] = self.psd_velocity_m2_s2_per_hz
        df["velocity_rms_m_s"] = self.band_rms_velocity()
        return df

    def to_csv(self, path) -> Path:
        """Write the spectrum in the format read by :meth:`from_csv` (SI, velocity).

        Band-constant spectra are written as ``kind: band_rms`` (band RMS velocity at the
        nominal centres), point-wise spectra as ``kind: psd``; values with 17 significant
        digits so that reading back is exact.
        """
        p = Path(path)
        lines = []
        if self.name:
            lines.append(f"# name: {self.name}")
        if self.bands is None:
            lines.append("# quantity: velocity; kind: psd; unit: (m/s)^2/Hz")
            pairs = zip(self.frequency_hz, self.psd_velocity_m2_s2_per_hz, strict=True)
            body = [f"{f!r},{v!r}" for f, v in ((float(a), float(b)) for a, b in pairs)]
        else:
            lines.append("# quantity: velocity; kind: band_rms; unit: m/s")
            body = [
                f"{lab},{float(v)!r}"
                for lab, v in zip(self.bands.labels, self.band_rms_velocity(), strict=True)
            ]
        try:
            p.write_text("\n".join([*lines, "frequency_hz,value", *body]) + "\n", encoding="utf-8")
        except OSError as exc:
            raise InputError(f"path: cannot write file '{p}': {exc}") from None
        return p


def _check_points(points_per_band) -> int:
    if isinstance(points_per_band, bool) or not isinstance(points_per_band, int | np.integer):
        raise InputError(f"points_per_band: expected an integer >= 2, got {points_per_band!r}")
    if points_per_band < 2:
        raise InputError(f"points_per_band: must be >= 2, got {points_per_band}")
    return int(points_per_band)


# --------------------------------------------------------------------------------------------
# Compliance
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Compliance:
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
