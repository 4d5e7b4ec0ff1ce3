"""Floor spectra from site-survey time histories (accelerometer or velocimeter records).

A record is a CSV file of one to three axes sampled at a constant rate, with either a time
column (``time_s``) or the rate in the header. The analysis (``docs/criteria.md``, section 5):

1. each axis is converted to SI velocity or acceleration and its mean is removed;
2. the record is cut into segments of ``nperseg`` samples with a Hann window and 50 % overlap;
   ``nperseg`` is the smallest power of two whose frequency resolution ``fs / nperseg`` puts at
   least :data:`MIN_BINS_PER_BAND` bins into the lowest band needed;
3. the one-sided PSD of every segment (a periodogram with density scaling, the terms Welch's
   method averages: :func:`scipy.signal.spectrogram`) is converted to a velocity PSD
   (``S_v = S_a / w^2``) and integrated over the IEC 61260-1 band edges
   (:mod:`isodesign.floor.bands`), each frequency bin counted with the fraction of its width
   that lies inside the band;
4. per band, the segments' band mean squares give the statistics a survey report quotes: the
   mean-square average (``mean``: the band RMS of the Welch PSD), the maximum (``max``) and a
   percentile of the segments' band RMS (``p90`` by default).

The result is a :class:`SurveyResult`; :meth:`SurveyResult.floor` turns one axis and one
statistic into a band-constant :class:`~isodesign.floor.FloorSpectrum`, usable wherever a floor
is.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from isodesign.domain import SAMPLE_RATE_DOMAIN_HZ
from isodesign.errors import InputError
from isodesign.floor.bands import Bands, third_octave_bands
from isodesign.floor.curves import criterion
from isodesign.floor.spectrum import FloorSpectrum
from isodesign.floor.units import _norm_unit, unit_factor

__all__ = [
    "MIN_BINS_PER_BAND",
    "NYQUIST_MARGIN",
    "SURVEY_STATISTICS",
    "SurveyRecord",
    "SurveyResult",
    "analyze_record",
    "floor_from_record",
    "is_record_csv",
    "read_record",
]

#: Frequency bins of the PSD required inside the lowest band (sets the segment length).
MIN_BINS_PER_BAND = 10
#: The highest band's upper edge must lie below ``fs / NYQUIST_MARGIN`` (the usable range of
#: an analyser with an anti-aliasing filter, 2.56 by custom; 2 would be Nyquist itself).
NYQUIST_MARGIN = 2.56
#: Overlap of successive segments (fraction of a segment); 50 % for the Hann window.
OVERLAP = 0.5
#: Time steps deviating from the median step by more than this fraction are gaps or jitter.
TIME_STEP_TOLERANCE = 0.01
#: Band statistics across segments.
SURVEY_STATISTICS = ("mean", "max", "percentile")
#: Units accepted for records: unit -> quantity.
_RECORD_QUANTITY = {"acceleration": "acceleration", "velocity": "velocity"}
_HEADER_KEYS = ("unit", "sample_rate_hz", "name", "quantity")


def _quantity_of(unit: str) -> str:
    for q in ("acceleration", "velocity"):
        try:
            unit_factor(q, unit)
            return q
        except InputError:
            continue
    raise InputError(
        f"unit: unknown record unit {unit!r}; valid: acceleration g, mg, ug, m/s^2, mm/s^2, "
        "um/s^2 or velocity m/s, mm/s, um/s, nm/s, in/s"
    )


@dataclass(frozen=True, eq=False)
class SurveyRecord:
    """A uniformly sampled record of one to three axes, in SI units.

    Attributes
    ----------
    sample_rate_hz : float
    axes : tuple of str
        Axis (column) names.
    data : ndarray, shape (n_samples, n_axes)
        Values in SI (m/s or m/s^2), mean not yet removed.
    quantity : {'velocity', 'acceleration'}
    unit : str
        The unit the file was written in.
    source : str
    """

    sample_rate_hz: float
    axes: tuple[str, ...]
    data: np.ndarray
    quantity: str
    unit: str
    source: str = ""

    @property
    def duration_s(self) -> float:
        """Record length, s."""
        return self.data.shape[0] / self.sample_rate_hz


def _header(path: Path) -> tuple[dict[str, str], int]:
    """``# key: value`` pairs of the leading comment lines and the number of those lines."""
    header: dict[str, str] = {}
    n = 0
    with path.open(encoding="utf-8-sig") as fh:
        for line in fh:
            s = line.strip()
            if s and not s.startswith("#"):
                break
            n += 1
            for part in s.lstrip("#").split(";"):
                if ":" in part:
                    k, v = part.split(":", 1)
                    header[k.strip().lower()] = v.strip()
    return header, n


def is_record_csv(path) -> bool:
    """True if ``path`` is a CSV time history (a ``time_s`` column or ``sample_rate_hz`` header).

    Parameters
    ----------
    path : str or Path
        A file (a missing or unreadable file is not a record).
    """
    p = Path(path)
    if not p.is_file():
        return False
    try:
        header, _ = _header(p)
        if "sample_rate_hz" in header:
            return True
        with p.open(encoding="utf-8-sig") as fh:
            for line in fh:
                s = line.strip()
                if s and not s.startswith("#"):
                    return s.split(",")[0].strip().lower() in ("time_s", "time")
    except (OSError, UnicodeDecodeError):
        return False
    return False


def read_record(path, *, unit: str | None = None, sample_rate_hz: float | None = None):
    """Read a survey record from CSV.

    Header comment lines ``# key: value; key: value`` give ``unit`` (g, mg, ug, m/s^2, mm/s^2,
    m/s, mm/s, um/s, ...; velocity or acceleration follows from it) and, without a time column,
    ``sample_rate_hz``. The first non-comment line names the columns: an optional ``time_s``
    (strictly increasing, uniform within 1 %), then one to three axes (e.g. ``x,y,z``).
    The arguments override the header.

    Parameters
    ----------
    path : str or Path
        The record.
    unit : str, optional
        Unit of the values (overrides the header).
    sample_rate_hz : float, optional
        Sample rate without a time column (overrides the header).

    Returns
    -------
    SurveyRecord

    Raises
    ------
    InputError
        Missing file, unknown or missing unit, no sample rate, non-numeric values or NaN,
        non-monotonic time or gaps, no axes or more than three.
    """
    import pandas as pd

    p = Path(path)
    where = f"record '{p}'"
    if not p.is_file():
        raise InputError(f"record: {where} not found")
    try:
        header, nskip = _header(p)
    except UnicodeDecodeError as exc:
        raise InputError(f"record: {where}: not a UTF-8 text file (undecodable byte at offset "
                         f"{exc.start}); a CSV time history is expected") from None
    except OSError as exc:
        raise InputError(f"record: {where}: cannot read ({exc.strerror or exc})") from None
    unit = unit if unit is not None else header.get("unit")
    if unit is None:
        raise InputError(
            f"unit: not given as an option (--unit) and not in the header of {where} "
            "(add a comment line '# unit: g')"
        )
    q = _quantity_of(unit)
    factor = unit_factor(q, unit)
    try:
        df = pd.read_csv(p, skiprows=nskip, comment="#", skipinitialspace=True)
    except (ValueError, pd.errors.ParserError) as exc:
        raise InputError(f"record: cannot parse {where}: {' '.join(str(exc).split())}") from None
    cols = [str(c).strip().lower() for c in df.columns]
    df.columns = cols
    if len(df) == 0:
        raise InputError(f"record: {where} has no data rows")
    for c in cols:
        if df[c].dtype.kind not in "fi":
            bad = pd.to_numeric(df[c], errors="coerce").isna() & df[c].notna()
            line = nskip + 2 + int(np.flatnonzero(bad.to_numpy())[0]) if bad.any() else None
            at = f" (line {line})" if line else ""
            raise InputError(f"record: {where}, column '{c}': non-numeric value{at}")
    arr = df.to_numpy(dtype=float)
    if not np.all(np.isfinite(arr)):
        i, j = np.argwhere(~np.isfinite(arr))[0]
        raise InputError(
            f"record: {where}, column '{cols[j]}', line {nskip + 2 + i}: NaN or missing value "
            "(fill or cut the record; gaps are not interpolated)"
        )
    tcol = next((i for i, c in enumerate(cols) if c in ("time_s", "time")), None)
    if tcol is not None:
        t = arr[:, tcol]
        dt = np.diff(t)
        if t.size < 2:
            raise InputError(f"record: {where} needs at least 2 samples")
        if np.any(dt <= 0):
            i = int(np.flatnonzero(dt <= 0)[0])
            raise InputError(
                f"record: {where}, column '{cols[tcol]}', line {nskip + 3 + i}: time is not "
                f"strictly increasing ({t[i]:.9g} then {t[i + 1]:.9g} s)"
            )
        step = float(np.median(dt))
        off = np.abs(dt / step - 1.0) > TIME_STEP_TOLERANCE
        if np.any(off):
            i = int(np.flatnonzero(off)[0])
            raise InputError(
                f"record: {where}, column '{cols[tcol]}', line {nskip + 3 + i}: time step "
                f"{dt[i]:.6g} s differs from the median step {step:.6g} s by more than "
                f"{TIME_STEP_TOLERANCE:.0%} (a gap or irregular sampling; resample or cut "
                "the record)"
            )
        fs = 1.0 / step
        if sample_rate_hz is not None and abs(sample_rate_hz * step - 1.0) > TIME_STEP_TOLERANCE:
            raise InputError(
                f"sample_rate_hz: {sample_rate_hz:g} Hz contradicts the time column of {where} "
                f"({fs:.6g} Hz)"
            )
        axes_idx = [i for i in range(len(cols)) if i != tcol]
    else:
        rate = sample_rate_hz if sample_rate_hz is not None else header.get("sample_rate_hz")
        if rate is None:
            raise InputError(
                f"sample_rate_hz: {where} has no time column ('time_s') and no "
                "'# sample_rate_hz: ...' header line; give one or --sample-rate"
            )
        try:
            fs = float(rate)
        except ValueError:
            raise InputError(f"sample_rate_hz: {rate!r} is not a number") from None
        if not math.isfinite(fs) or fs <= 0:
            raise InputError(f"sample_rate_hz: must be finite and > 0 Hz, got {rate}")
        axes_idx = list(range(len(cols)))
    lo, hi = SAMPLE_RATE_DOMAIN_HZ
    if not lo <= fs <= hi:
        raise InputError(f"sample_rate_hz: must be in [{lo:g}, {hi:g}] Hz (a survey "
                         f"record's), got {fs:g} Hz ({where})")
    if not 1 <= len(axes_idx) <= 3:
        raise InputError(
            f"record: {where} must have 1 to 3 axis columns besides the time, got "
            f"{len(axes_idx)} ({', '.join(cols)})"
        )
    data = arr[:, axes_idx] * factor
    data.flags.writeable = False
    return SurveyRecord(
        sample_rate_hz=fs,
        axes=tuple(cols[i] for i in axes_idx),
        data=data,
        quantity=q,
        unit=_norm_unit(unit),
        source=str(p),
    )


@dataclass(frozen=True, eq=False)
class SurveyResult:
    """Band RMS velocity statistics of a survey record.

    Attributes
    ----------
    bands : Bands
    axes : tuple of str
    mean_rms_m_s, max_rms_m_s, percentile_rms_m_s : ndarray, shape (n_axes, n_bands)
        Mean-square average (Welch), maximum and ``percentile`` of the segments' band RMS
        velocity, m/s.
    percentile : float
    segment_rms_m_s : ndarray, shape (n_axes, n_segments, n_bands)
        Every segment's band RMS velocity.
    frequency_hz : ndarray
        PSD frequencies of the segments; ``psd_velocity`` the Welch (mean) velocity PSD,
        shape (n_axes, n_freq), (m/s)^2/Hz.
    sample_rate_hz, duration_s, segment_s : float
    n_segments : int
    quantity, source : str
    """

    bands: Bands
    axes: tuple[str, ...]
    mean_rms_m_s: np.ndarray
    max_rms_m_s: np.ndarray
    percentile_rms_m_s: np.ndarray
    percentile: float
    segment_rms_m_s: np.ndarray = field(repr=False)
    frequency_hz: np.ndarray = field(repr=False)
    psd_velocity: np.ndarray = field(repr=False)
    sample_rate_hz: float = 0.0
    duration_s: float = 0.0
    segment_s: float = 0.0
    n_segments: int = 0
    quantity: str = ""
    source: str = ""

    def statistic(self, statistic: str = "mean", axis: str | None = None) -> np.ndarray:
        """Band RMS velocity (m/s) of one axis for ``mean``, ``max`` or ``percentile``."""
        if statistic not in SURVEY_STATISTICS:
            raise InputError(
                f"statistic: unknown {statistic!r}; valid: {', '.join(SURVEY_STATISTICS)}"
            )
        i = self._axis_index(axis)
        return {
            "mean": self.mean_rms_m_s,
            "max": self.max_rms_m_s,
            "percentile": self.percentile_rms_m_s,
        }[statistic][i]

    def _axis_index(self, axis: str | None) -> int:
        if axis is None:
            if len(self.axes) == 1:
                return 0
            if "z" in self.axes:
                return self.axes.index("z")
            raise InputError(
                f"axis: the record has axes {', '.join(self.axes)}; choose one (no 'z' column)"
            )
        key = axis.strip().lower()
        if key not in self.axes:
            raise InputError(f"axis: {axis!r} is not in the record; valid: {', '.join(self.axes)}")
        return self.axes.index(key)

    def floor(self, statistic: str = "mean", axis: str | None = None) -> FloorSpectrum:
        """A band-constant :class:`FloorSpectrum` of one axis and statistic."""
        i = self._axis_index(axis)
        v = self.statistic(statistic, self.axes[i])
        label = statistic if statistic != "percentile" else f"p{self.percentile:g}"
        return FloorSpectrum.from_band_rms(
            self.bands,
            v,
            name=f"survey {Path(self.source).stem} {self.axes[i]} {label}",
            source=self.source,
        )

    def to_frame(self):
        """One row per (axis, band): band RMS velocity statistics in m/s and um/s."""
        import pandas as pd

        frames = []
        for i, a in enumerate(self.axes):
            df = self.bands.to_frame()
            df.insert(0, "axis", a)
            for nm, arr in (
                ("mean", self.mean_rms_m_s),
                ("max", self.max_rms_m_s),
                (f"p{self.percentile:g}", self.percentile_rms_m_s),
            ):
                df[f"velocity_rms_{nm}_m_s"] = arr[i]
                df[f"velocity_rms_{nm}_um_s"] = arr[i] / 1e-6
            frames.append(df)
        out = pd.concat(frames, ignore_index=True)
        out.attrs.update(
            sample_rate_hz=self.sample_rate_hz,
            duration_s=self.duration_s,
            segment_s=self.segment_s,
            n_segments=self.n_segments,
        )
        return out

    def summary(self) -> str:
        """A few lines: record, analysis, the worst band against VC curves."""
        lines = [
            f"record {self.source}: {len(self.axes)} axis/axes ({', '.join(self.axes)}), "
            f"{self.quantity}, {self.sample_rate_hz:g} Hz, {self.duration_s:.1f} s",
            f"Welch: Hann window, {self.segment_s:.4g} s segments, {OVERLAP:.0%} overlap, "
            f"{self.n_segments} segments; bands {self.bands.labels[0]} to "
            f"{self.bands.labels[-1]} Hz",
        ]
        vc = [criterion(f"VC-{c}") for c in "ABCDEFG"]
        for i, a in enumerate(self.axes):
            v = self.mean_rms_m_s[i]
            j = int(np.argmax(v))
            met = [c.name for c in vc if np.all(v <= c.velocity_rms_m_s(_vc_bands(self.bands)))]
            lines.append(
                f"axis {a}: max band RMS (mean) {v[j] / 1e-6:.3g} um/s at "
                f"{self.bands.labels[j]} Hz; meets {met[-1] if met else 'no VC curve'}"
                + ("" if _vc_bands(self.bands) is self.bands else " (within 1-80 Hz)")
            )
        if self.n_segments < 8:
            lines.append(
                f"note: only {self.n_segments} segments; the maximum and percentile are rough"
            )
        return "\n".join(lines)

    def plot(self, path, *, dpi: int = 130) -> Path:
        """Band RMS velocity per axis (mean, max, percentile) against the VC curves."""
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        fig = Figure(figsize=(9.0, 4.8), layout="constrained")
        FigureCanvasAgg(fig)
        ax = fig.add_subplot(1, 1, 1)
        c = self.bands.centre_hz
        colors = ("C0", "C1", "C2")
        for i, a in enumerate(self.axes):
            ax.step(c, self.mean_rms_m_s[i] / 1e-6, where="mid", color=colors[i],
                    label=f"{a}: mean-square average")  # fmt: skip
            ax.step(c, self.max_rms_m_s[i] / 1e-6, where="mid", color=colors[i], ls=":",
                    label=f"{a}: maximum")  # fmt: skip
            ax.step(c, self.percentile_rms_m_s[i] / 1e-6, where="mid", color=colors[i],
                    ls="--", label=f"{a}: p{self.percentile:g}")  # fmt: skip
        vb = _vc_bands(self.bands)
        for letter in "ABCDEFG":
            cv = criterion(f"VC-{letter}")
            ax.plot(vb.centre_hz, cv.velocity_rms_m_s(vb) / 1e-6, color="0.6", lw=0.8)
            ax.text(vb.centre_hz[-1] * 1.15, cv.velocity_rms_m_s(vb)[-1] / 1e-6,
                    cv.name, fontsize=7, va="center", color="0.4")  # fmt: skip
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlim(c[0] / 1.15, max(c[-1], vb.centre_hz[-1]) * 1.6)
        ax.set_xlabel("one-third-octave band centre (Hz)")
        ax.set_ylabel("band RMS velocity (um/s)")
        ax.set_title(f"{Path(self.source).name}: {self.duration_s:.0f} s, "
                     f"{self.n_segments} segments")  # fmt: skip
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.06, 1.0))
        p = Path(path)
        fig.savefig(p, dpi=dpi)
        return p


def _vc_bands(bands: Bands) -> Bands:
    """The bands within the VC curves' range (1-80 Hz)."""
    n = bands.nominal_hz
    m = (n >= 1.0 - 1e-9) & (n <= 80.0 + 1e-9)
    if m.all():
        return bands
    return Bands(tuple(np.asarray(bands.index)[m].tolist()))


def _segment_length(fs: float, lowest: Bands) -> int:
    bw = float(lowest.bandwidth_hz[0])
    return int(2 ** math.ceil(math.log2(MIN_BINS_PER_BAND * fs / bw)))


def _band_matrix(freq: np.ndarray, df: float, bands: Bands) -> np.ndarray:
    """Weights (n_bands, n_freq): the fraction of each bin [f - df/2, f + df/2] in each band."""
    lo = freq - df / 2.0
    hi = freq + df / 2.0
    fl = bands.lower_hz[:, None]
    fu = bands.upper_hz[:, None]
    return np.clip(np.minimum(hi, fu) - np.maximum(lo, fl), 0.0, None) / df


def analyze_record(
    record: SurveyRecord,
    *,
    f_min_hz: float = 1.0,
    f_max_hz: float = 80.0,
    percentile: float = 90.0,
) -> SurveyResult:
    """Band RMS velocity statistics of a record (method in the module docstring).

    Parameters
    ----------
    record : SurveyRecord
    f_min_hz, f_max_hz : float
        Band range (nominal centres), default 1 to 80 Hz (the VC curves' range).
    percentile : float
        Percentile of the segments' band RMS reported besides the mean and maximum (0-100).

    Raises
    ------
    InputError
        Sample rate too low for the highest band, record too short for the lowest band.
    """
    from scipy import signal

    if not 0.0 <= percentile <= 100.0:
        raise InputError(f"percentile: must be in [0, 100], got {percentile:g}")
    bands = third_octave_bands(f_min_hz, f_max_hz)
    fs = record.sample_rate_hz
    top = float(bands.upper_hz[-1])
    if top > fs / NYQUIST_MARGIN:
        raise InputError(
            f"sample_rate_hz: {fs:g} Hz is too low for the {bands.labels[-1]} Hz band (upper "
            f"edge {top:.4g} Hz needs at least {NYQUIST_MARGIN} x {top:.4g} = "
            f"{NYQUIST_MARGIN * top:.4g} Hz); lower --fmax (f_max_hz) or record faster"
        )
    nper = _segment_length(fs, Bands((bands.index[0],)))
    n = record.data.shape[0]
    if n < nper:
        raise InputError(
            f"record: {record.duration_s:.4g} s is too short for the {bands.labels[0]} Hz band: "
            f"one segment with {MIN_BINS_PER_BAND} frequency bins in that band takes "
            f"{nper / fs:.4g} s ({nper} samples at {fs:g} Hz); raise --fmin (f_min_hz) or record "
            "longer"
        )
    nover = int(nper * OVERLAP)
    x = record.data - record.data.mean(axis=0)
    freq, _, sxx = signal.spectrogram(
        x.T, fs=fs, window="hann", nperseg=nper, noverlap=nover, detrend=False,
        scaling="density", mode="psd", axis=-1,
    )  # fmt: skip
    # sxx: (n_axes, n_freq, n_seg); to velocity PSD
    keep = (freq > 0) & (freq <= top + fs / nper)
    freq = freq[keep]
    sxx = sxx[:, keep, :]
    if record.quantity == "acceleration":
        sxx = sxx / (2.0 * math.pi * freq[None, :, None]) ** 2
    w = _band_matrix(freq, fs / nper, bands)  # (n_bands, n_freq)
    ms = np.einsum("bf,afs->asb", w, sxx) * (fs / nper)  # (n_axes, n_seg, n_bands)
    seg_rms = np.sqrt(ms)
    mean = np.sqrt(ms.mean(axis=1))
    return SurveyResult(
        bands=bands,
        axes=record.axes,
        mean_rms_m_s=mean,
        max_rms_m_s=seg_rms.max(axis=1),
        percentile_rms_m_s=np.percentile(seg_rms, percentile, axis=1),
        percentile=float(percentile),
        segment_rms_m_s=seg_rms,
        frequency_hz=freq,
        psd_velocity=sxx.mean(axis=2),
        sample_rate_hz=fs,
        duration_s=record.duration_s,
        segment_s=nper / fs,
        n_segments=int(ms.shape[1]),
        quantity=record.quantity,
        source=record.source,
    )


def floor_from_record(
    path, *, statistic: str = "mean", axis: str | None = None, **kwargs
) -> FloorSpectrum:
    """Read and analyze a record; the floor of one axis and statistic (1-80 Hz bands).

    Parameters
    ----------
    path : str or Path
        The record (:func:`read_record`).
    statistic : {'mean', 'max', 'percentile'}
        Band statistic across segments.
    axis : str, optional
        Axis column (default ``z``, or the only axis).
    **kwargs
        ``f_min_hz``, ``f_max_hz``, ``percentile`` go to :func:`analyze_record`; ``unit``,
        ``sample_rate_hz`` to :func:`read_record`.

    Returns
    -------
    FloorSpectrum
    """
    read_kw = {k: kwargs.pop(k) for k in ("unit", "sample_rate_hz") if k in kwargs}
    return analyze_record(read_record(path, **read_kw), **kwargs).floor(statistic, axis)
