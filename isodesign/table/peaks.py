"""The continuous peak of |T| of a table design, between the NLP's frequencies (NumPy).

The NLP bounds ``|T_p,aa|`` (every instrument point ``p``, axis ``a``) at its grid's
frequencies only, and that grid starts where the floor and target bands start (0.89 Hz for
the built-in table), above the lowest rigid-body modes of a soft table. The peak
constraint is semi-infinite: :func:`continuous_peaks` measures each point and axis' peak on
a fine log grid from :data:`LOW_FRACTION` of the lowest modal frequency to
:data:`HIGH_FACTOR` times the highest one (or the top of the NLP's peak rows), refined by a
parabola in ``ln f`` through the largest sample;
:func:`isodesign.optimization.table_driver.optimize_table` adds the frequencies of the peaks
above the bound to the NLP's movable peak frequencies and solves again (docs/table.md, section 11).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from isodesign.response.linearization import equivalent_amplitude
from isodesign.spring.capillary import statistical_resistance_function
from isodesign.spring.equations import air_stiffness, spring_stiffness
from isodesign.table.assembly import AXES

__all__ = ["HIGH_FACTOR", "LOW_FRACTION", "PEAK_SAMPLES", "TablePeaks", "closure_springs",
           "continuous_peaks", "peak_search_band"]

#: The fine grid starts at this fraction of the lowest modal frequency.
LOW_FRACTION = 0.5
#: ... and ends at this multiple of the highest one (or the NLP's peak rows' top).
HIGH_FACTOR = 2.0
#: Log-spaced samples of the fine grid.
PEAK_SAMPLES = 4001


def closure_springs(model, sigma, sigma_u):
    """``omega -> [Cx]``: each isolator's vertical spring linearized at a closure state.

    Parameters
    ----------
    model : TableModel
    sigma, sigma_u : ndarray (n,)
        Stroke and tube-velocity RMS per isolator.
    """
    from isodesign.spring.diaphragm import diaphragm_model

    dia = diaphragm_model(model.diaphragm)

    def springs(omega):
        w = np.asarray(omega, float)
        out = []
        for i, d in enumerate(model.designs):
            c = statistical_resistance_function(model.flow, d, w)(float(sigma_u[i]))
            out.append(spring_stiffness(air_stiffness(d, w, c, model.flow),
                                        dia.stiffness(w, equivalent_amplitude(float(sigma[i])))))
        return out

    return springs


@dataclass(frozen=True)
class TablePeaks:
    """The continuous peak of ``|T_p,aa|`` per instrument point and axis.

    Attributes
    ----------
    peak_db : ndarray (k, 3)
        ``20 log10 |T_p,aa|`` at the peak, dB.
    frequency_hz : ndarray (k, 3)
        Frequency of each peak, Hz.
    f_low_hz, f_high_hz : float
        The fine grid's ends.
    point_names : tuple of str
    """

    peak_db: np.ndarray
    frequency_hz: np.ndarray
    f_low_hz: float
    f_high_hz: float
    point_names: tuple

    @property
    def max_db(self) -> float:
        """The largest peak over points and axes, dB."""
        return float(np.max(self.peak_db))

    def worst(self) -> tuple[str, str, float, float]:
        """``(point, axis, peak dB, frequency Hz)`` of the largest peak."""
        p, a = np.unravel_index(int(np.argmax(self.peak_db)), self.peak_db.shape)
        return (self.point_names[p], AXES[a], float(self.peak_db[p, a]),
                float(self.frequency_hz[p, a]))

    def axis_peak_db(self) -> np.ndarray:
        """The largest peak per axis (over points), shape (3,)."""
        return self.peak_db.max(axis=0)

    def above(self, limit_db: float, tol_db: float) -> list[tuple[float, float]]:
        """``(excess dB, frequency Hz)`` of every point-axis peak above ``limit + tol``,
        largest excess first."""
        out = [(float(self.peak_db[p, a] - limit_db), float(self.frequency_hz[p, a]))
               for p in range(self.peak_db.shape[0]) for a in range(3)
               if self.peak_db[p, a] > limit_db + tol_db]
        return sorted(out, reverse=True)

    def to_frame(self):
        """One row per point and axis: peak (dB) and its frequency (Hz)."""
        import pandas as pd

        rows = [(name, ax, float(self.peak_db[p, a]), float(self.frequency_hz[p, a]))
                for p, name in enumerate(self.point_names) for a, ax in enumerate(AXES)]
        return pd.DataFrame(rows, columns=["point", "axis", "peak_db", "frequency_hz"])


def peak_search_band(modes, f_top_hz: float) -> tuple[float, float]:
    """The fine grid's ends from the modes: ``(LOW_FRACTION f_min, max(HIGH_FACTOR f_max,
    f_top_hz))``.

    Parameters
    ----------
    modes : TableModes
        The design's six modes (springs at its closure); unstable modes (NaN) are skipped.
    f_top_hz : float
        The top of the NLP's peak rows, Hz (the grid's resonance region).

    Returns
    -------
    (float, float)
        Hz. Without a finite mode: ``(f_top_hz / 100, f_top_hz)``.
    """
    f = np.asarray(modes.frequency_hz, float)
    f = f[np.isfinite(f) & (f > 0)]
    if not f.size:
        return f_top_hz / 100.0, f_top_hz
    return LOW_FRACTION * float(f.min()), max(HIGH_FACTOR * float(f.max()), f_top_hz)


def continuous_peaks(model, sigma, sigma_u, f_low_hz: float, f_high_hz: float,
                     samples: int = PEAK_SAMPLES) -> TablePeaks:
    """Peak of ``|T_p,aa|`` per point and axis between ``f_low_hz`` and ``f_high_hz``.

    Parameters
    ----------
    model : TableModel
        The design's table model (:func:`isodesign.table.model.table_model`).
    sigma, sigma_u : ndarray (n,)
        Stroke (m) and tube-velocity (m/s) RMS per isolator: the statistical closure at which
        every spring is linearized (as in the band response and in the NLP).
    f_low_hz, f_high_hz : float
        The search band, Hz (:func:`peak_search_band`).
    samples : int
        Log-spaced samples.

    Returns
    -------
    TablePeaks

    Notes
    -----
    Through the largest sample ``i`` of each curve and its two neighbours, the parabola
    ``y = c2 x^2 + c1 x + c0`` with ``x = ln(f / f_i)`` and ``y`` in dB gives the peak
    ``c0 - c1^2 / (4 c2)`` at ``f_i exp(-c1 / (2 c2))``; a curve that is not concave there
    (or peaks at an end of the band) gives its largest sample.
    """
    f = np.geomspace(f_low_hz, f_high_hz, int(samples))
    w = 2.0 * math.pi * f
    out = model.outputs(closure_springs(model, sigma, sigma_u)(w), w)
    diag = np.diagonal(out.points, axis1=2, axis2=3)  # (f, k, 3)
    t2 = diag.real ** 2 + diag.imag ** 2
    k = t2.shape[1]
    peak = np.empty((k, 3))
    freq = np.empty((k, 3))
    for p in range(k):
        for a in range(3):
            y_all = 10.0 * np.log10(t2[:, p, a])
            i = int(np.argmax(y_all))
            peak[p, a], freq[p, a] = y_all[i], f[i]
            if 0 < i < f.size - 1:
                x = np.log(f[i - 1: i + 2] / f[i])
                c2, c1, c0 = np.polyfit(x, y_all[i - 1: i + 2], 2)
                if c2 < 0:
                    peak[p, a] = c0 - c1 * c1 / (4.0 * c2)
                    freq[p, a] = f[i] * math.exp(-c1 / (2.0 * c2))
    return TablePeaks(peak_db=peak, frequency_hz=freq, f_low_hz=float(f_low_hz),
                      f_high_hz=float(f_high_hz),
                      point_names=tuple(model.table.point_names))
