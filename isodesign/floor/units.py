"""Units and conversions of floor-vibration quantities.

Displacement, velocity and acceleration, as band RMS values or PSDs, in SI or the units a
survey report uses (um/s, uin/s, mm/s^2, ug ...). SI inside: m, m/s, m/s^2; PSDs in
(quantity)^2/Hz; frequencies in Hz. Band RMS <-> PSD assumes a PSD flat within the band
(``docs/criteria.md``).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from types import MappingProxyType
from typing import Any

import numpy as np

from isodesign.errors import InputError, check_choice, check_finite_array
from isodesign.floor.bands import (
    Bands,
)

__all__ = [
    "QUANTITIES",
    "STANDARD_GRAVITY_M_S2",
    "band_rms_to_psd",
    "convert_band_rms",
    "convert_psd",
    "psd_to_band_rms",
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
