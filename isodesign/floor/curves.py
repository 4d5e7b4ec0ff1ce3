"""Named floor-vibration criterion curves (VC, ISO-derived, NIST-A) and their registry.

Band RMS velocity limits in one-third-octave bands: the generic VC curves VC-A ... VC-G, the
older VC-A / VC-B variants with a constant-acceleration segment (``VC-A-legacy``,
``VC-B-legacy``, UNCONFIRMED), ISO-derived building curves and NIST-A. Look them up with
:func:`criterion`; list them with :func:`criterion_names`; sources in ``docs/criteria.md``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

from isodesign.errors import InputError, check_choice, check_finite_array, check_positive
from isodesign.floor.bands import (
    Bands,
    third_octave_bands,
)
from isodesign.floor.units import (
    _INCH,
    _ORDER,
    _REL_TOL,
    _TWO_PI,
    QUANTITIES,
    STANDARD_GRAVITY_M_S2,
    unit_factor,
)

__all__ = [
    "CriterionCurve",
    "CurveSegment",
    "criteria_table",
    "criterion",
    "criterion_names",
]


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
        Band RMS value in SI (m, m/s or m/s^2); with ``exponent`` its value at 1 Hz.
    exponent : float
        The quantity varies as ``value * (f_m / 1 Hz) ** exponent`` over the segment (``f_m``
        the band's exact centre); 0 (default) holds it constant. The ISO 2631-2 z-axis curve
        has ``-0.5`` in acceleration from 1 to 4 Hz.
    """

    f_lo_hz: float
    f_hi_hz: float
    quantity: str
    value: float
    exponent: float = 0.0

    def __post_init__(self):
        lo = check_positive("f_lo_hz", self.f_lo_hz, unit="Hz")
        hi = check_positive("f_hi_hz", self.f_hi_hz, unit="Hz")
        if lo > hi:
            raise InputError(f"f_lo_hz: must be <= f_hi_hz ({hi:g} Hz), got {lo:g} Hz")
        check_choice("quantity", self.quantity, QUANTITIES)
        check_positive("value", self.value)
        e = float(self.exponent)
        if not np.isfinite(e) or abs(e) > 4:
            raise InputError(f"exponent: must be finite and in [-4, 4], got {self.exponent!r}")


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
                v = s.value * c**s.exponent * w ** (1 - _ORDER[s.quantity])
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
    "(operating theatre 1, residential night 1.4, residential day 2, office 4, workshop 8), "
    "also ISO 10137:2007 Annex C; as tabulated with the VC curves by Gordon (1991), Proc. SPIE "
    "1619, and in the ASHRAE Handbook - HVAC Applications (noise and vibration control)"
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


_ISO_LEGACY_NOTE = (
    "ISO 2631-2:1989 was withdrawn in 2003 (the 2003 edition gives no magnitudes): the curve "
    "is derived from the 1989 base curve, as building-vibration practice still uses it. "
)


def _iso(label: str, factor: float, um_s: float, shape: str = "z") -> CriterionCurve:
    """ISO-derived building curve: ``factor`` times the ISO 2631-2:1989 base curve.

    ``shape``: ``'z'`` (vertical base curve, the default curves), ``'xy'`` (horizontal base
    curve) or ``'const-accel'`` (the project's earlier shape: constant acceleration below 8 Hz).
    """
    v = um_s * 1e-6
    suffix = {"z": "", "xy": "-xy", "const-accel": "-const-accel"}[shape]
    if shape == "z":
        a1, a4 = 0.01 * factor, 0.005 * factor
        segs = (
            CurveSegment(1.0, 4.0, "acceleration", a1, -0.5),
            CurveSegment(4.0, 8.0, "acceleration", a4),
            CurveSegment(8.0, 80.0, "velocity", v),
        )
        desc = (
            f"ISO-derived building curve '{label}' (factor {factor:g} on the ISO 2631-2:1989 "
            f"z-axis base curve): band RMS acceleration {a1 * 1e3:.3g} f^-1/2 mm/s^2 over 1 to "
            f"4 Hz, {a4 * 1e3:.3g} mm/s^2 over 4 to 8 Hz, {um_s:g} um/s band RMS velocity over "
            "8 to 80 Hz"
        )
        note = (
            _ISO_LEGACY_NOTE
            + f"Above 8 Hz the tabulated {um_s:g} um/s is used (the base curve's 0.005 m/s^2 at "
            f"8 Hz is {0.005 * factor / (_TWO_PI * 8) * 1e6:.4g} um/s). Bands on a boundary "
            "(4, 8 Hz) take the smaller value."
        )
    elif shape == "xy":
        a = 0.0036 * factor
        vxy = a / (_TWO_PI * 2.0)
        segs = (
            CurveSegment(1.0, 2.0, "acceleration", a),
            CurveSegment(2.0, 80.0, "velocity", vxy),
        )
        desc = (
            f"ISO-derived building curve '{label}', horizontal (x-y) form (factor {factor:g} on "
            f"the ISO 2631-2:1989 x-y base curve): band RMS acceleration {a * 1e3:.3g} mm/s^2 "
            f"over 1 to 2 Hz, then {vxy * 1e6:.4g} um/s band RMS velocity over 2 to 80 Hz"
        )
        note = (
            _ISO_LEGACY_NOTE
            + "The velocity is the 1-2 Hz acceleration plateau at 2 Hz (3.6 mm/s^2 / (2 pi "
            "2 Hz) = 286.5 um/s for factor 1). The 2 Hz band takes the smaller value."
        )
    else:
        a = v * _TWO_PI * 8.0
        segs = (
            CurveSegment(1.0, 8.0, "acceleration", a),
            CurveSegment(8.0, 80.0, "velocity", v),
        )
        desc = (
            f"ISO-derived building curve '{label}', constant-acceleration variant (factor "
            f"{factor:g}): {um_s:g} um/s band RMS velocity over 8 to 80 Hz; constant band RMS "
            f"acceleration {a * 1e3:.3g} mm/s^2 (= {um_s:g} um/s at 8 Hz) over 1 to 8 Hz"
        )
        note = (
            "Project choice below 8 Hz (the earlier default shape): constant acceleration "
            "2 pi (8 Hz) v, i.e. the ISO z-axis 4-8 Hz plateau (5.0 mm/s^2 x factor) extended "
            "down to 1 Hz; stricter than the ISO z-axis curve below 4 Hz (twice as strict at "
            "1 Hz). The 8 Hz band takes the velocity value."
        )
    return CriterionCurve(
        name=f"ISO-{label}{suffix}",
        description=desc,
        source=_ISO_SOURCE + ("; x-y (horizontal) base curve" if shape == "xy" else ""),
        segments=segs,
        note=note,
    )


_ISO_LEVELS = (
    ("workshop", 8, 800.0),
    ("office", 4, 400.0),
    ("residential-day", 2, 200.0),
    ("residential-night", 1.4, 140.0),
    ("operating-theatre", 1, 100.0),
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
    *(_iso(label, factor, um_s) for label, factor, um_s in _ISO_LEVELS),
    *(_iso(label, factor, um_s, "xy") for label, factor, um_s in _ISO_LEVELS),
    *(_iso(label, factor, um_s, "const-accel") for label, factor, um_s in _ISO_LEVELS),
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
    if names is not None:
        if isinstance(names, str) or not all(isinstance(n, str) for n in names):
            raise InputError(f"names: expected a sequence of criterion names, got {names!r:.60}")
        if len(names) == 0:
            raise InputError("names: empty; give at least one criterion name (valid: "
                             f"{', '.join(criterion_names())}), or None for all")
    curves = [criterion(n) for n in (names if names is not None else criterion_names())]
    if not any(c.covers(bands).any() for c in curves):
        raise InputError(f"f_min_hz, f_max_hz: no band of {f_min_hz:g}-{f_max_hz:g} Hz lies on "
                         f"the curve of {', '.join(c.name for c in curves)}")
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
