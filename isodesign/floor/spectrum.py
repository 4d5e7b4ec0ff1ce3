"""Floor spectra: the one-sided floor velocity PSD under the isolators.

:class:`FloorSpectrum` is either point-wise (log-log interpolated) or piecewise constant per
one-third-octave band (a floor built from a curve or from measured band RMS values), with
exact band integration.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from isodesign.errors import InputError, check_choice, check_finite_array
from isodesign.floor.bands import (
    BAND_INDEX_MAX,
    BAND_INDEX_MIN,
    Bands,
    band_index_near,
    band_power_weight,
    third_octave_bands,
)
from isodesign.floor.curve_files import (
    _check_frequencies,
    _check_values,
    _column,
    _numbers,
    _read_csv,
)
from isodesign.floor.curves import CriterionCurve, criterion
from isodesign.floor.units import (
    _ORDER,
    _REL_TOL,
    _TWO_PI,
    QUANTITIES,
    _norm_unit,
    _out,
    band_rms_to_psd,
    convert_psd,
    unit_factor,
)
from isodesign.results import ResultDisplay

__all__ = [
    "FloorSpectrum",
]


def _readonly(a) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.flags.writeable = False
    return a


@dataclass(frozen=True, eq=False, repr=False)
class FloorSpectrum(ResultDisplay):
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
    def _summary_items(self) -> list[tuple[str, str]]:
        """Name, kind, range and source (for repr and notebooks)."""
        items = [("name", self.name or "(unnamed)"), ("kind", self.kind),
                 ("range", f"{self.f_min_hz:.3g}-{self.f_max_hz:.3g} Hz"),
                 ("points", str(len(self.frequency_hz)))]
        if self.source:
            items.append(("source", self.source if len(self.source) < 60
                          else self.source[:57] + "..."))
        return items

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
