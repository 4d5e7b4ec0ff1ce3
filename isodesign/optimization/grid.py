"""The NLP's frequency grid: floor quadrature, peak grid, movable peak slots, one point."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from isodesign.numerics.cplx import Cx
from isodesign.optimization.objectives import OBJECTIVES
from isodesign.response.isolator import natural_frequency_hz
from isodesign.response.linearization import response_grid

__all__ = ["DEFAULT_POINT_FREQUENCY_HZ", "Grid", "build_grid", "take"]

#: Frequency of the ``transmissibility_at`` objective when the study names none.
DEFAULT_POINT_FREQUENCY_HZ = 10.0


@dataclass(frozen=True, eq=False)
class Grid:
    """Frequencies at which the NLP evaluates the spring, and their roles.

    ``omega`` concatenates the floor quadrature grid (``n_floor`` points, for
    sigma and the band mean squares), the peak grid (``n_peak`` log-spaced
    points for the resonance peak) and, for an objective at one frequency, one point.
    """

    omega: np.ndarray
    n_floor: int
    n_peak: int
    response: Any  # isodesign.response.linearization.ResponseGrid of the floor part
    target_band_rows: np.ndarray  # rows of the response grid's bands that are target bands
    target_limit_m_s: np.ndarray
    point_index: int | None = None
    n_slots: int = 0  # the last n_slots peak-grid points: movable (NLP parameters)

    @property
    def slot_slice(self) -> slice:
        """The movable peak-grid frequencies."""
        end = self.n_floor + self.n_peak
        return slice(end - self.n_slots, end)

    def with_slots(self, slot_hz) -> Grid:
        """The same grid with the movable peak frequencies set (Hz)."""
        w = self.omega.copy()
        w[self.slot_slice] = 2.0 * math.pi * np.asarray(slot_hz, float)
        return dataclasses.replace(self, omega=w)

    @property
    def floor_slice(self) -> slice:
        """The floor quadrature grid."""
        return slice(0, self.n_floor)

    @property
    def peak_slice(self) -> slice:
        """The peak grid (movable slots included)."""
        return slice(self.n_floor, self.n_floor + self.n_peak)


def build_grid(study, *, points_per_band: int | None = None,
               objectives: tuple = (), extra_peak_hz: tuple = (), slots: int = 0) -> Grid:
    """The NLP's frequency grid for a study (NumPy).

    Parameters
    ----------
    study : Study
        Floor spectrum, target criterion and bands, payload, the start design,
        ``models.points_per_band`` and ``models.peak_points``, the natural
        frequency bounds and the objective.
    points_per_band : int, optional
        Quadrature points per one-third-octave band of the floor grid; default
        ``study.models["points_per_band"]``.
    objectives : tuple of str
        Further objective kinds the NLP carries (a Pareto study's second one);
        if any of them, or the study's own objective, is evaluated at one
        frequency (``transmissibility_at``), that frequency is appended.
    extra_peak_hz : tuple of float
        Fixed frequencies (Hz) merged into the peak grid (sorted, duplicates
        removed).
    slots : int
        Number of movable peak-grid frequencies appended after the fixed ones
        (the exchange method of :func:`isodesign.optimization.driver.optimize`).
        They start as copies of the lowest peak frequencies, which changes no
        constraint value, until :meth:`Grid.with_slots` moves them.

    Returns
    -------
    Grid
        ``omega`` (rad/s) is the floor grid of
        :func:`isodesign.response.linearization.response_grid`, then the peak grid
        (slots last), then the one objective frequency if any
        (``point_index``).

    Notes
    -----
    The peak grid has ``models.peak_points`` log-spaced frequencies from
    ``max(0.05 Hz, f_lo / 4)`` to ``6 f_hi``, with ``f_lo`` the smaller of the start
    design's natural frequency (air spring alone, ``sqrt(k_s / (N + 1) / (m/n)) / 2 pi``)
    and ``constraints.min_natural_frequency_hz``, and
    ``f_hi`` the larger of that natural frequency and
    ``constraints.max_natural_frequency_hz``: with both bounds set, every natural
    frequency they allow lies well inside it (without them, the span rests on the
    start design's natural frequency only). The one objective frequency is
    ``objective.frequency_hz``, default :data:`DEFAULT_POINT_FREQUENCY_HZ`.
    """

    ppb = points_per_band or study.models["points_per_band"]
    rg = response_grid(study.floor, study.bands, target=study.target, points_per_band=ppb)
    rows = np.arange(len(rg.bands), dtype=int)
    limits = np.asarray(rg.limit_velocity_m_s, float)
    d0 = study.start_design()
    # peak grid: from a quarter of the lowest to six times the highest plausible
    # natural frequency
    m_i = study.payload.mass_per_isolator_kg
    fn0 = natural_frequency_hz(d0.static_stiffness_n_per_m, m_i)
    f_lo = max(0.05, 0.25 * min(fn0, study.constraints.get("min_natural_frequency_hz") or fn0))
    f_hi = 6.0 * max(fn0, study.constraints.get("max_natural_frequency_hz") or fn0)
    peak = np.geomspace(f_lo, f_hi, study.models["peak_points"])
    if extra_peak_hz:
        peak = np.unique(np.concatenate([peak, np.asarray(extra_peak_hz, float)]))
    if slots:
        peak = np.concatenate([peak, peak[:slots]])
    parts = [rg.omega, 2.0 * math.pi * peak]
    point = None
    if any(OBJECTIVES[k].at_frequency for k in (study.objective["kind"], *objectives)):
        point = rg.omega.size + peak.size
        f_pt = study.objective.get("frequency_hz", DEFAULT_POINT_FREQUENCY_HZ)
        parts.append(np.array([2.0 * math.pi * f_pt]))
    return Grid(omega=np.concatenate(parts), n_floor=rg.omega.size, n_peak=peak.size,
                response=rg, target_band_rows=rows, target_limit_m_s=limits,
                point_index=point, n_slots=slots)


def take(c: Cx, sl) -> Cx:
    """The rows ``sl`` of a complex pair.

    Parameters
    ----------
    c : Cx
        Complex pair (real and imaginary parts as NumPy arrays or CasADi columns).
    sl : slice or index array
        Rows to take (e.g. :attr:`Grid.floor_slice`, :attr:`Grid.peak_slice`).

    Returns
    -------
    Cx
        ``Cx(c.re[sl], c.im[sl])``, same backend as ``c``.
    """
    return Cx(c.re[sl], c.im[sl])
