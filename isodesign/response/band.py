"""The payload's band response to a random floor: the result type.

:class:`BandResponse` is what :func:`~isodesign.response.random_input.band_response` (the
closure solved on the 1-DOF payload) and
:func:`~isodesign.response.random_input.band_response_at` (the closure state given, e.g.
solved on the symmetric table's z DOF) return.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from isodesign.plotting.response import band_response_figure, draw_bands, judged_mask
from isodesign.plotting.style import OPTIMUM
from isodesign.response.isolator import Payload
from isodesign.response.linearization import ResponseGrid, velocity_margin_db
from isodesign.response.scope import response_scope
from isodesign.response.stability import StabilityFigures
from isodesign.results import ResultDisplay
from isodesign.spring.diagnostics import MAX_STATIC_PRESSURE_PA

__all__ = ["BandResponse"]


@dataclass(frozen=True, eq=False, repr=False)
class BandResponse(ResultDisplay):
    """Payload band response to a random floor, with the compliance verdict.

    Attributes
    ----------
    grid : ResponseGrid
        Frequencies and quadrature weights (``grid.bands`` the bands).
    transmissibility : ndarray of complex (n_points,)
        ``T`` on ``grid.frequency_hz`` at the final linearization.
    transmissibility_linear : ndarray of complex (n_points,)
        ``T`` at :data:`LINEAR_REFERENCE_AMPLITUDE_M` (the starting point).
    floor_velocity_rms_m_s : ndarray (n_bands,)
    payload_velocity_rms_m_s, payload_displacement_rms_m, payload_acceleration_rms_m_s2 :
        ndarray (n_bands,)
    limit_velocity_rms_m_s : ndarray (n_bands,)
        The target curve.
    stroke_rms_m : float
        RMS stroke ``sigma`` computed from the final ``T``.
    equivalent_amplitude_m : float
        ``A* = 1.880 sigma`` (the amplitude the spring sees with the default method).
    stability : StabilityFigures
        With the excited peak at the final linearization.
    spring_diagnostics : StiffnessResult
        The spring at the final linearization (shape (n_points,), or (n_points, nodes) for
        ``random_method='rayleigh'``); ``.warnings`` lists validity flags.
    iterations : int
        Evaluations of the closure, the linear start excluded: one spring evaluation each
        for the harmonic closures; for ``statistical`` the evaluations of the inner (tube
        velocity) iteration, one vectorized expression on the grid each.
    converged : bool
    closure_slope : float or None
        ``d ln sigma_new / d ln sigma`` at the solution (< 1: a stable, locally unique fixed
        point).
    random_method, flow, amplitude_mode, diaphragm, floor_name, target_name : str
    design : SpringDesign
    payload : Payload
    tube_velocity_rms_m_s : float or None
        RMS ``sigma_u`` of the capillary's mean velocity at the final linearization
        (``random_method='statistical'``; ``None`` for the harmonic closures).
    distortion_kurtosis : float or None
        The tube velocity's kurtosis the distortion power was evaluated at
        (``distortion=True``; ``docs/random-response.md`` section 3c), else ``None``.
    flags : tuple of str
        The closure's own validity flags (the distortion's, :attr:`warnings` lists them
        after the spring's).
    """

    grid: ResponseGrid
    transmissibility: np.ndarray
    transmissibility_linear: np.ndarray
    floor_velocity_rms_m_s: np.ndarray
    payload_velocity_rms_m_s: np.ndarray
    payload_displacement_rms_m: np.ndarray
    payload_acceleration_rms_m_s2: np.ndarray
    limit_velocity_rms_m_s: np.ndarray
    stroke_rms_m: float
    equivalent_amplitude_m: float
    stability: StabilityFigures
    spring_diagnostics: Any
    iterations: int
    converged: bool
    closure_slope: float | None
    random_method: str
    flow: str
    amplitude_mode: str
    diaphragm: str
    floor_name: str = ""
    target_name: str = ""
    design: Any = field(repr=False, default=None)
    payload: Payload | None = None
    tube_velocity_rms_m_s: float | None = None
    distortion_kurtosis: float | None = None
    flags: tuple = ()

    @property
    def bands(self):
        """The one-third-octave bands."""
        return self.grid.bands

    @property
    def margin_db(self) -> np.ndarray:
        """``20 log10(limit / payload)`` per band (positive: below the limit)."""
        return velocity_margin_db(self.limit_velocity_rms_m_s, self.payload_velocity_rms_m_s)

    @property
    def band_passes(self) -> np.ndarray:
        """Payload band RMS velocity <= limit, per band."""
        return self.payload_velocity_rms_m_s <= self.limit_velocity_rms_m_s

    @property
    def passes(self) -> bool:
        """True when every band meets the target and the design is inside the model's
        hard validity limits (:attr:`outside_validity` empty)."""
        return bool(np.all(self.band_passes)) and not self.outside_validity

    @property
    def outside_validity(self) -> tuple[str, ...]:
        """Why the answer cannot be trusted at all, whatever the bands say (empty: none).

        Today the static chamber pressure: a payload that needs p0 above
        :data:`~isodesign.spring.diagnostics.MAX_STATIC_PRESSURE_PA` is outside the ideal
        gas and rolling-diaphragm assumptions, so its verdict is FAIL, not a PASS with a
        warning.
        """
        p0 = self.stability.pressure_pa
        if p0 is not None and p0 > MAX_STATIC_PRESSURE_PA:
            return (f"p0 = {p0 / 1e5:.4g} bar abs exceeds the model's validity limit "
                    f"{MAX_STATIC_PRESSURE_PA / 1e5:g} bar (static_pressure: ideal gas and "
                    "rolling diaphragm); more isolators or a larger piston area lower it",)
        return ()

    @property
    def worst_band_hz(self) -> float:
        """Nominal centre of the band with the smallest margin."""
        return float(self.bands.nominal_hz[int(np.argmin(self.margin_db))])

    @property
    def worst_band_label(self) -> str:
        """Label of that band."""
        return self.bands.labels[int(np.argmin(self.margin_db))]

    @property
    def worst_margin_db(self) -> float:
        """Smallest margin over the bands, dB."""
        return float(np.min(self.margin_db))

    @property
    def warnings(self) -> tuple[str, ...]:
        """Validity warnings of the spring model at the final linearization, then the
        closure's (:attr:`flags`)."""
        return (*self.spring_diagnostics.warnings, *self.flags)

    def verdict(self) -> str:
        """One line: PASS/FAIL, worst band and margin."""
        n = len(self.bands)
        nfail = int(np.sum(~self.band_passes))
        head = (
            f"{self.target_name} met in all {n} bands"
            if nfail == 0
            else f"{self.target_name} exceeded in {nfail} of {n} bands"
        )
        tail = f"; worst band {self.worst_band_label} Hz, margin {self.worst_margin_db:+.2f} dB"
        if self.outside_validity:
            return ("FAIL: outside the model's validity: " + "; ".join(self.outside_validity)
                    + f" (bands, not to be trusted: {head}{tail})")
        return ("PASS: " if nfail == 0 else "FAIL: ") + head + tail

    def to_frame(self):
        """One row per band: floor, payload (v, x, a), target, margin and pass."""
        import pandas as pd

        df = pd.DataFrame(self.columns())
        df.attrs.update(
            floor=self.floor_name,
            target=self.target_name,
            stroke_rms_m=self.stroke_rms_m,
            equivalent_amplitude_m=self.equivalent_amplitude_m,
            random_method=self.random_method,
            flow=self.flow,
            amplitude_mode=self.amplitude_mode,
            diaphragm=self.diaphragm,
            verdict=self.verdict(),
        )
        return df

    def columns(self) -> dict:
        """The columns of :meth:`to_frame` (name -> array or list), without pandas (a run's
        ``bands.csv``: :func:`isodesign.io.csvtable.columns_csv`).

        Returns
        -------
        dict
        """
        return {**self.bands.columns(),
                "floor_velocity_rms_m_s": self.floor_velocity_rms_m_s,
                "payload_velocity_rms_m_s": self.payload_velocity_rms_m_s,
                "payload_displacement_rms_m": self.payload_displacement_rms_m,
                "payload_acceleration_rms_m_s2": self.payload_acceleration_rms_m_s2,
                "limit_velocity_rms_m_s": self.limit_velocity_rms_m_s,
                "margin_db": self.margin_db,
                "passes": self.band_passes}

    def transmissibility_frame(self):
        """``T`` on the grid: final linearization and linear regime."""
        import pandas as pd

        t, tl = self.transmissibility, self.transmissibility_linear
        return pd.DataFrame(
            {
                "frequency_hz": self.grid.frequency_hz,
                "transmissibility_abs": np.abs(t),
                "transmissibility_phase_deg": np.degrees(np.angle(t)),
                "linear_transmissibility_abs": np.abs(tl),
            }
        )

    def _summary_items(self) -> list[tuple[str, str]]:
        """Verdict, worst band, operating amplitude and models (for repr and notebooks)."""
        return [
            ("", "PASS" if self.passes else "FAIL"),
            ("worst band", f"{self.worst_band_label} Hz {self.worst_margin_db:+.2f} dB"),
            ("bands", f"{len(self.bands)} ({self.bands.labels[0]}-{self.bands.labels[-1]} Hz)"),
            ("floor", self.floor_name),
            ("limit", self.target_name),
            ("stroke A*", f"{self.equivalent_amplitude_m * 1e6:.4g} um"),
            ("natural frequency", f"{self.stability.natural_frequency_hz:.4g} Hz"),
            ("models", f"{self.flow} flow, {self.amplitude_mode}, {self.diaphragm} diaphragm"),
            ("validity flags", str(len(self.warnings))),
            ("scope", self.scope.short()),
        ]

    @property
    def scope(self):
        """What this answer covers and leaves out (:class:`~isodesign.response.scope.Scope`)."""
        s = self.stability
        return response_scope(self.payload, self.diaphragm, s.static_stiffness_n_per_m,
                              s.air_static_stiffness_n_per_m, self.floor_name)

    def plot(self, ax=None, *, judged=None, title=None, peak_limit_db=None):
        """Floor, payload and limit per band; |T| in dB and its phase.

        Parameters
        ----------
        ax : matplotlib Axes, optional
            Draw the band panel only, into this axes. Default: a new figure with the
            band panel and the transmissibility (dB and phase) at the operating
            amplitude and in the linear regime.
        judged : ndarray of bool or (lo, hi), optional
            Judged bands (shaded; failing ones circled); default all.
        title : str, optional
        peak_limit_db : float, optional
            A peak-|T| limit line.

        Returns
        -------
        matplotlib.figure.Figure
            Made with an Agg canvas; the global Matplotlib backend is not touched.
        """
        if ax is not None:
            mask = judged if judged is None or not isinstance(judged, tuple) \
                else judged_mask(self.bands, judged)
            draw_bands(ax, [("payload", self, OPTIMUM)], judged=mask)
            if title:
                ax.set_title(title, fontsize=10)
            return ax.figure
        return band_response_figure(self, judged=judged, title=title,
                                    peak_limit_db=peak_limit_db)
