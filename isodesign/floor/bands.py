"""One-third-octave frequency bands per IEC 61260-1 (base 10).

Definitions (IEC 61260-1:2014, base-10 system, fractional-octave designator b = 3):

* octave frequency ratio ``G = 10**0.3``;
* exact mid-band (centre) frequency of band ``x`` (an integer)
  ``f_m = 1000 Hz * G**(x/3) = 10**(3 + x/10) Hz`` (``x = 0`` is 1 kHz, ``x = -30`` is 1 Hz);
* band edges ``f_l = f_m * G**(-1/6)``, ``f_u = f_m * G**(+1/6)``, so that ``f_l * f_u = f_m**2``
  and the relative bandwidth is ``G**(1/6) - G**(-1/6) = 0.23077``;
* nominal (labelled) centre: the standard's preferred number for the band, the mantissa
  1, 1.25, 1.6, 2, 2.5, 3.15, 4, 5, 6.3, 8 repeated by decades (1 Hz, 1.25 Hz, ... 80 Hz ...).

Bands with index -50 to 20 (nominal 0.01 Hz to 100 kHz) are supported.

Only numpy is imported at module level; pandas is imported inside :meth:`Bands.to_frame`.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from isodesign.errors import InputError, check_positive

__all__ = [
    "BAND_INDEX_MAX",
    "BAND_INDEX_MIN",
    "RELATIVE_BANDWIDTH",
    "Bands",
    "band_index_near",
    "band_power_weight",
    "third_octave_bands",
]

#: Octave frequency ratio of the base-10 system, ``G = 10**0.3``.
G = 10.0**0.3
#: Relative bandwidth of a one-third-octave band, ``G**(1/6) - G**(-1/6)`` (0.23077).
RELATIVE_BANDWIDTH = 10.0**0.05 - 10.0**-0.05
#: Smallest supported band index (nominal 0.01 Hz).
BAND_INDEX_MIN = -50
#: Largest supported band index (nominal 100 kHz).
BAND_INDEX_MAX = 20

_MANTISSA = ("1", "1.25", "1.6", "2", "2.5", "3.15", "4", "5", "6.3", "8")
_REL_TOL = 1e-9


def _centre(x):
    return 10.0 ** (3.0 + np.asarray(x, dtype=float) / 10.0)


def _edge(x_half):
    # Edges are computed from the half-integer index so that the upper edge of band x and the
    # lower edge of band x + 1 are bitwise identical floats.
    return 10.0 ** (3.0 + np.asarray(x_half, dtype=float) / 10.0)


def _nominal(x: int) -> float:
    return float(f"{_MANTISSA[x % 10]}e{x // 10 + 3}")


def _label(x: int) -> str:
    return f"{_nominal(x):g}"


def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.flags.writeable = False
    return a


@dataclass(frozen=True)
class Bands:
    """An ordered set of one-third-octave bands (IEC 61260-1, base 10).

    Parameters
    ----------
    index : tuple of int
        IEC band numbers ``x``, strictly increasing, each in [-50, 20]
        (``x = -30`` is the 1 Hz band, ``x = 0`` the 1 kHz band).

    Notes
    -----
    The arrays ``centre_hz``, ``lower_hz``, ``upper_hz``, ``bandwidth_hz`` and ``nominal_hz``
    are computed from ``index`` (read-only numpy arrays). Two ``Bands`` are equal when their
    indices are equal. Source: IEC 61260-1:2014, clause 5 (base-10 system, b = 3).
    """

    index: tuple[int, ...]

    def __post_init__(self):
        try:
            raw = tuple(self.index)
        except TypeError:
            raise InputError(
                f"index: expected a sequence of integers, got {self.index!r}"
            ) from None
        idx = []
        for v in raw:
            try:
                ok = not isinstance(v, bool | str) and float(v).is_integer()
            except (TypeError, ValueError):
                ok = False
            if not ok:
                raise InputError(f"index: band numbers must be integers, got {v!r}")
            iv = int(v)
            if not BAND_INDEX_MIN <= iv <= BAND_INDEX_MAX:
                raise InputError(
                    f"index: band number {iv} outside the supported range "
                    f"[{BAND_INDEX_MIN}, {BAND_INDEX_MAX}] (nominal 0.01 Hz to 100 kHz)"
                )
            idx.append(iv)
        if not idx:
            raise InputError("index: at least one band is required")
        if any(b <= a for a, b in itertools.pairwise(idx)):
            raise InputError(f"index: band numbers must be strictly increasing, got {idx}")
        object.__setattr__(self, "index", tuple(idx))

    def __len__(self) -> int:
        return len(self.index)

    @property
    def index_array(self) -> np.ndarray:
        """Band numbers as an integer array."""
        a = np.array(self.index, dtype=int)
        a.flags.writeable = False
        return a

    @property
    def centre_hz(self) -> np.ndarray:
        """Exact mid-band frequencies ``10**(3 + x/10)`` in Hz."""
        return _readonly(_centre(self.index))

    @property
    def lower_hz(self) -> np.ndarray:
        """Lower band edges ``f_m * G**(-1/6)`` in Hz."""
        return _readonly(_edge(np.array(self.index, dtype=float) - 0.5))

    @property
    def upper_hz(self) -> np.ndarray:
        """Upper band edges ``f_m * G**(1/6)`` in Hz."""
        return _readonly(_edge(np.array(self.index, dtype=float) + 0.5))

    @property
    def bandwidth_hz(self) -> np.ndarray:
        """Band widths ``f_u - f_l`` in Hz."""
        return _readonly(self.upper_hz - self.lower_hz)

    @property
    def nominal_hz(self) -> np.ndarray:
        """Nominal (preferred-number) centre frequencies in Hz."""
        return _readonly([_nominal(x) for x in self.index])

    @property
    def labels(self) -> tuple[str, ...]:
        """Nominal centre frequencies as strings, e.g. ``'1.25'``, ``'31.5'``, ``'1000'``."""
        return tuple(_label(x) for x in self.index)

    @property
    def is_contiguous(self) -> bool:
        """True when the bands are consecutive (no gap between them)."""
        return all(b == a + 1 for a, b in itertools.pairwise(self.index))

    def to_frame(self):
        """Return a DataFrame with one row per band.

        Returns
        -------
        pandas.DataFrame
            Columns ``index``, ``label``, ``nominal_hz``, ``centre_hz``, ``lower_hz``,
            ``upper_hz``, ``bandwidth_hz``.
        """
        import pandas as pd

        return pd.DataFrame(self.columns())

    def columns(self) -> dict:
        """The columns of :meth:`to_frame` (name -> array or list), without pandas.

        Returns
        -------
        dict
        """
        return {
            "index": np.array(self.index, dtype=int),
            "label": list(self.labels),
            "nominal_hz": self.nominal_hz,
            "centre_hz": self.centre_hz,
            "lower_hz": self.lower_hz,
            "upper_hz": self.upper_hz,
            "bandwidth_hz": self.bandwidth_hz,
        }


def third_octave_bands(f_min_hz: float = 1.0, f_max_hz: float = 80.0) -> Bands:
    """One-third-octave bands whose nominal centre lies in ``[f_min_hz, f_max_hz]``.

    Parameters
    ----------
    f_min_hz, f_max_hz : float
        Frequency range in Hz, ``0 < f_min_hz <= f_max_hz``. A band is included when its
        *nominal* centre (1, 1.25, ..., 80 Hz ...) lies in the closed range (relative
        tolerance 1e-9), so ``third_octave_bands(1, 80)`` gives the 20 bands 1 ... 80 Hz
        (the 80 Hz band's exact centre is 79.43 Hz). Supported nominal centres: 0.01 Hz to
        100 kHz.

    Returns
    -------
    Bands

    Raises
    ------
    InputError
        Non-positive, non-finite or reversed range, or no band in the range.

    Notes
    -----
    Source: IEC 61260-1:2014, base-10 system, b = 3.
    """
    lo = check_positive("f_min_hz", f_min_hz, unit="Hz")
    hi = check_positive("f_max_hz", f_max_hz, unit="Hz")
    if lo > hi:
        raise InputError(f"f_min_hz: must be <= f_max_hz ({hi:g} Hz), got {lo:g} Hz")
    candidates = range(BAND_INDEX_MIN, BAND_INDEX_MAX + 1)
    idx = [x for x in candidates if lo * (1 - _REL_TOL) <= _nominal(x) <= hi * (1 + _REL_TOL)]
    if not idx:
        raise InputError(
            f"f_min_hz, f_max_hz: no one-third-octave band has its nominal centre in "
            f"[{lo:g}, {hi:g}] Hz (supported nominal centres: 0.01 Hz to 100 kHz)"
        )
    return Bands(tuple(idx))


def band_index_near(frequency_hz: float, rel_tol: float = 0.02) -> int | None:
    """IEC band number whose exact centre is within ``rel_tol`` of ``frequency_hz``, else None.

    Nominal centres differ from exact centres by at most 0.95 %, so both ``1.25`` and
    ``1.2589`` map to band -29 with the default 2 % tolerance.

    Parameters
    ----------
    frequency_hz : float
        A frequency, Hz.
    rel_tol : float
        Relative tolerance on the band centre.
    """
    f = float(frequency_hz)
    if not math.isfinite(f) or f <= 0:
        return None
    x = round(10.0 * (math.log10(f) - 3.0))
    if not BAND_INDEX_MIN <= x <= BAND_INDEX_MAX:
        return None
    if abs(f / float(_centre(x)) - 1.0) <= rel_tol:
        return int(x)
    return None


def band_power_weight(bands: Bands, power: int) -> np.ndarray:
    """Exact band integral of ``(2 pi f)**power`` over each band, in Hz * (rad/s)**power.

    ``power`` is an even integer: ``0`` gives the bandwidth ``f_u - f_l``; ``-2`` gives
    ``(1/f_l - 1/f_u) / (2 pi)**2`` (displacement from a velocity PSD flat in the band);
    ``2`` gives ``(2 pi)**2 (f_u**3 - f_l**3) / 3`` (acceleration).

    For a velocity PSD ``S`` constant in a band, the band mean square of the quantity
    ``(2 pi f)**(power/2) * v`` is ``S * band_power_weight(bands, power)``.

    Parameters
    ----------
    bands : Bands
        The bands.
    power : int
        Even exponent of ``2 pi f``.
    """
    if power % 2:
        raise InputError(f"power: must be an even integer, got {power!r}")
    fl, fu = bands.lower_hz, bands.upper_hz
    n = power + 1
    w = (2.0 * math.pi) ** power
    if n == 0:  # pragma: no cover - power is even, n is odd
        return w * np.log(fu / fl)
    return w * (fu**n - fl**n) / n
