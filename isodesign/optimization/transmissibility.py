"""Transmissibility of a study's design for harmonic floor motion: the question the study asks.

:func:`transmissibility` answers every study (``isodesign transmissibility`` calls it):

* a study with ``[table]``: the table in six degrees of freedom
  (:class:`TableTransmissibility`). For each floor amplitude and each floor axis (x, y, z)
  the floor translates harmonically along that axis and every isolator's spring is closed
  on its own stroke amplitude (:func:`~isodesign.table.harmonic.table_harmonic_response`);
  the answer is ``T[f, amplitude, point, axis out, axis in]``, labelled by
  :meth:`TableTransmissibility.to_frame`. It also carries the continuous peak of
  ``|T_p,aa|`` per point and axis with every spring linearized at the band response's
  closure on the study's floor: the figure the report prints and the optimizer's peak
  constraint bounds (:func:`~isodesign.table.peaks.continuous_peaks`, docs/table.md,
  section 11);
* a study without ``[table]``: the payload on its isolators (one DOF), the stroke closed
  self-consistently with every coexisting root counted
  (:func:`~isodesign.response.harmonic.harmonic_response`).

A table study never gets the vertical answer: the result's type says which question was
answered (``TableTransmissibility`` or ``HarmonicResponse``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from isodesign.errors import InputError
from isodesign.results import ResultDisplay
from isodesign.table.assembly import AXES

__all__ = ["DEFAULT_FLOOR_AMPLITUDES_M", "DEFAULT_FREQUENCY_HZ", "TableTransmissibility",
           "table_transmissibility", "transmissibility"]

#: Default floor amplitudes (m) and frequencies (Hz, 0.5 to 50 Hz, 200 log-spaced) of
#: :func:`transmissibility` (the CLI's defaults).
DEFAULT_FLOOR_AMPLITUDES_M = (1e-6, 1e-5)
DEFAULT_FREQUENCY_HZ = tuple(np.geomspace(0.5, 50.0, 200))


@dataclass(frozen=True, eq=False, repr=False)
class TableTransmissibility(ResultDisplay):
    """Transmissibility of a table for harmonic floor motion, per point and axis.

    Attributes
    ----------
    frequency_hz : ndarray (n_f,)
    floor_amplitude_m : ndarray (n_a,)
    transmissibility : ndarray (n_f, n_a, k, 3, 3) complex
        ``[f, floor amplitude, point, axis out, axis in]``: the motion of an instrument
        point along ``axis out`` per unit floor motion along ``axis in``, each isolator
        closed on its own stroke amplitude.
    stroke_amplitude_m : ndarray (n_f, n_a, 3, n)
        Each isolator's vertical stroke amplitude, per floor axis.
    converged : ndarray of bool (n_f, n_a, 3)
        Whether the per-isolator closure converged (a point that did not is flagged).
    point_names : tuple of str
    closure_peaks : TablePeaks or None
        The continuous peak of ``|T_p,aa|`` with the springs at the band response's
        closure on the study's floor (the report's and the optimizer's figure); None for a
        table given without a study.
    peak_limit_db : float or None
        The study's ``max_peak_transmissibility_db``.
    model : TableModel
    notes : tuple of str
    """

    frequency_hz: np.ndarray
    floor_amplitude_m: np.ndarray
    transmissibility: np.ndarray
    stroke_amplitude_m: np.ndarray
    converged: np.ndarray
    point_names: tuple
    model: object
    closure_peaks: object = None
    peak_limit_db: float | None = None
    notes: tuple = ()

    def peak_db(self) -> np.ndarray:
        """Largest ``|T_p,aa|`` (dB) over the frequencies, per amplitude, point and axis.

        Returns
        -------
        ndarray (n_a, k, 3)
        """
        return 20.0 * np.log10(self._diagonal().max(axis=0))

    def peak_frequency_hz(self) -> np.ndarray:
        """Frequency (Hz) of each :meth:`peak_db`, shape (n_a, k, 3)."""
        return self.frequency_hz[np.argmax(self._diagonal(), axis=0)]

    def _diagonal(self) -> np.ndarray:
        """``|T_p,aa|``, shape (n_f, n_a, k, 3)."""
        return np.abs(np.diagonal(self.transmissibility, axis1=3, axis2=4))

    def peaks_frame(self):
        """One row per floor amplitude, point and axis: the peak of ``|T_p,aa|``.

        Returns
        -------
        pandas.DataFrame
            ``floor_amplitude_m``, ``point``, ``axis``, ``peak_db``, ``frequency_hz`` and
            ``max_stroke_m`` (the largest isolator stroke under that axis' floor motion).
        """
        import pandas as pd

        pk, pf = self.peak_db(), self.peak_frequency_hz()
        rows = [(float(xf), name, ax, float(pk[j, p, a]), float(pf[j, p, a]),
                 float(self.stroke_amplitude_m[:, j, a, :].max()))
                for j, xf in enumerate(self.floor_amplitude_m)
                for p, name in enumerate(self.point_names) for a, ax in enumerate(AXES)]
        return pd.DataFrame(rows, columns=["floor_amplitude_m", "point", "axis", "peak_db",
                                           "frequency_hz", "max_stroke_m"])

    def to_frame(self):
        """One row per floor amplitude, frequency, point, floor axis and point axis.

        Returns
        -------
        pandas.DataFrame
            ``floor_amplitude_m``, then the columns of
            :func:`~isodesign.table.frames.transmissibility_frame` (``frequency_hz``,
            ``point``, ``axis_in``, ``axis_out``, ``transmissibility_abs``,
            ``transmissibility_db``, ``phase_deg``), then ``converged`` (the closure at that
            frequency, amplitude and floor axis).
        """
        import pandas as pd

        from isodesign.table.frames import transmissibility_frame

        parts = []
        k = len(self.point_names)
        for j, xf in enumerate(self.floor_amplitude_m):
            df = transmissibility_frame(self.frequency_hz, self.transmissibility[:, j],
                                        self.point_names)
            df.insert(0, "floor_amplitude_m", float(xf))
            # rows by frequency, point, axis in, axis out: repeat each (f, axis in) flag
            conv = self.converged[:, j, :]  # (f, axis in)
            df["converged"] = np.broadcast_to(conv[:, None, :, None],
                                              (conv.shape[0], k, 3, 3)).ravel()
            parts.append(df)
        return pd.concat(parts, ignore_index=True)

    def plot(self, ax=None):
        """``|T_p,aa|`` (dB) of every point and axis against frequency, per floor amplitude.

        Parameters
        ----------
        ax : matplotlib Axes, optional
            Draw into it (every axis in one panel); default a figure with one panel per
            floor axis.

        Returns
        -------
        matplotlib.figure.Figure
        """
        from isodesign.plotting.style import candidate_style, new_figure

        if ax is None:
            fig = new_figure(10.0, 3.8)
            axes = list(fig.subplots(1, 3, sharey=True))
        else:
            fig, axes = ax.figure, [ax] * 3
        lines = ("-", "--", ":", "-.")
        diag = self._diagonal()
        with np.errstate(divide="ignore"):
            db = 20.0 * np.log10(diag)
        for a, axis in enumerate(AXES):
            for p, name in enumerate(self.point_names):
                st = candidate_style(p)
                for j, xf in enumerate(self.floor_amplitude_m):
                    axes[a].semilogx(self.frequency_hz, db[:, j, p, a], color=st["color"],
                                     ls=lines[j % len(lines)], lw=max(2.4 - 0.8 * p, 1.0),
                                     label=f"{name} {axis}, {xf:g} m")
            if self.peak_limit_db is not None:
                axes[a].axhline(self.peak_limit_db, color="tab:red", lw=0.9, ls="--",
                                label=f"limit {self.peak_limit_db:g} dB")
            axes[a].axhline(0.0, color="0.55", lw=0.8)
            axes[a].set_xlabel("frequency (Hz)")
            axes[a].set_title(f"|T| {axis}: point {axis} per floor {axis}", fontsize=9)
            axes[a].grid(True, which="major", alpha=0.4)
            axes[a].legend(fontsize=6, loc="lower left")
        axes[0].set_ylabel("|T| (dB)")
        return fig

    def text(self) -> str:
        """The peaks as text: the closure's continuous peak per axis, then per amplitude."""
        lines = []
        cp = self.closure_peaks
        if cp is not None:
            lines.append(
                f"  peak |T| per axis over every point at the band response's closure (the "
                f"report's and the optimizer's), continuous from {cp.f_low_hz:.3g} to "
                f"{cp.f_high_hz:.3g} Hz: " + ", ".join(
                    f"{ax} {cp.peak_db[:, i].max():+.2f} dB at "
                    f"{cp.frequency_hz[int(np.argmax(cp.peak_db[:, i])), i]:.3g} Hz"
                    for i, ax in enumerate(AXES))
                + ("" if self.peak_limit_db is None else
                   f"; limit {self.peak_limit_db:g} dB"
                   + (" (ABOVE it)" if cp.max_db > self.peak_limit_db + 0.01 else "")))
        lines += [f"  {'floor ampl.':>11}  {'point':>10}  {'axis':>4}  {'peak |T|':>8}  "
                  f"{'at (Hz)':>8}  {'max stroke':>10}  {'not conv.':>9}",
                  f"  {'':>11}  {'':>10}  {'':>4}  {'(dB)':>8}"]
        pk, pf = self.peak_db(), self.peak_frequency_hz()
        for j, xf in enumerate(self.floor_amplitude_m):
            for p, name in enumerate(self.point_names):
                for a, ax in enumerate(AXES):
                    lines.append(
                        f"  {xf * 1e6:>8.4g} um  {name[:10]:>10}  {ax:>4}  {pk[j, p, a]:>8.2f}  "
                        f"{pf[j, p, a]:>8.4g}  "
                        f"{self.stroke_amplitude_m[:, j, a, :].max() * 1e6:>7.4g} um  "
                        f"{int(np.sum(~self.converged[:, j, a])):>9d}")
        return "\n".join(lines)

    def _summary_items(self) -> list[tuple[str, str]]:
        pk = self.peak_db()
        j, p, a = np.unravel_index(int(np.argmax(pk)), pk.shape)
        items = [("frequencies", f"{self.frequency_hz.size} ({self.frequency_hz.min():.3g}.."
                                 f"{self.frequency_hz.max():.3g} Hz)"),
                 ("floor amplitudes", ", ".join(f"{v:g} m" for v in self.floor_amplitude_m)),
                 ("points", ", ".join(self.point_names)),
                 ("largest peak", f"{pk[j, p, a]:.2f} dB ({self.point_names[p]} {AXES[a]}, "
                                  f"{self.floor_amplitude_m[j]:g} m)"),
                 ("converged", f"{int(self.converged.sum())} of {self.converged.size}")]
        if self.closure_peaks is not None:
            items.append(("closure peak", f"{self.closure_peaks.max_db:.2f} dB"))
        return items


def table_transmissibility(design, table, frequency_hz, floor_amplitude_m, *,
                           flow: str = "quasi_steady", amplitude_mode: str = "self_consistent",
                           diaphragm="viscoelastic", closure_peaks=None,
                           peak_limit_db: float | None = None) -> TableTransmissibility:
    """A table's transmissibility under harmonic floor motion along x, y and z.

    Parameters
    ----------
    design : SpringDesign
    table : Table
    frequency_hz : array_like
        Frequencies, Hz.
    floor_amplitude_m : float or array_like
        Floor displacement amplitudes, m.
    flow, amplitude_mode, diaphragm : str
        Spring models.
    closure_peaks : TablePeaks, optional
        The continuous peaks at the band response's closure (:func:`transmissibility`
        supplies them for a study).
    peak_limit_db : float, optional
        The peak limit drawn and compared.

    Returns
    -------
    TableTransmissibility
    """
    from isodesign.errors import check_positive
    from isodesign.table.harmonic import table_harmonic_response

    if np.ndim(floor_amplitude_m) > 1:
        raise InputError("floor_amplitude_m: expected one or more amplitudes in m, > 0")
    amps = np.atleast_1d(check_positive("floor_amplitude_m", floor_amplitude_m, unit="m",
                                        allow_array=True)).astype(float)
    if amps.ndim != 1 or not amps.size:
        raise InputError("floor_amplitude_m: expected one or more amplitudes in m, > 0")
    t_cols, s_cols, c_cols = [], [], []
    model = None
    for xf in amps:
        t_ax, s_ax, c_ax = [], [], []
        for axis in AXES:
            r = table_harmonic_response(design, table, frequency_hz, float(xf), axis,
                                        flow=flow, amplitude_mode=amplitude_mode,
                                        diaphragm=diaphragm)
            t_ax.append(r.transmissibility)  # (f, k, 3 out)
            s_ax.append(r.stroke_amplitude_m)  # (f, n)
            c_ax.append(r.converged)
            model = r.model
        t_cols.append(np.stack(t_ax, axis=-1))  # (f, k, 3 out, 3 in)
        s_cols.append(np.stack(s_ax, axis=1))  # (f, 3, n)
        c_cols.append(np.stack(c_ax, axis=-1))  # (f, 3)
    f = np.atleast_1d(np.asarray(r.frequency_hz, float))
    return TableTransmissibility(
        frequency_hz=f, floor_amplitude_m=amps, transmissibility=np.stack(t_cols, axis=1),
        stroke_amplitude_m=np.stack(s_cols, axis=1), converged=np.stack(c_cols, axis=1),
        point_names=tuple(model.table.point_names), model=model, closure_peaks=closure_peaks,
        peak_limit_db=peak_limit_db,
        notes=("harmonic floor translation along one axis at a time; each isolator's spring "
               "closed on its own stroke amplitude, the branch reached from small amplitudes",))


def study_closure_peaks(study, design, table, models: dict):
    """The continuous peak of ``|T_p,aa|`` as the report computes it: every spring at the
    band response's closure on the study's floor, searched from half the lowest mode.

    Parameters
    ----------
    study : Study
        With ``[table]``.
    design : SpringDesign
    table : Table
        The study's table (its levers at the design's values).
    models : dict
        ``flow``, ``amplitude_mode``, ``diaphragm``.

    Returns
    -------
    TablePeaks
    """
    from isodesign.optimization.table_problem import PEAK_ROWS_MAX_HZ
    from isodesign.table.modes import table_modes
    from isodesign.table.peaks import closure_springs, continuous_peaks, peak_search_band
    from isodesign.table.response import table_band_response

    res = table_band_response(design, table, study.floor_axes, study.target, bands=study.bands,
                              flow=models["flow"], amplitude_mode=models["amplitude_mode"],
                              diaphragm=models["diaphragm"], warn=False,
                              distortion=bool(models.get("distortion", False)))  # one closure
    model = res.model
    modes = table_modes(model, vertical=closure_springs(model, res.stroke_rms_m,
                                                        res.closure_tube_velocity_m_s))
    return continuous_peaks(model, res.stroke_rms_m, res.closure_tube_velocity_m_s,
                            *peak_search_band(modes, PEAK_ROWS_MAX_HZ))


def peak_limit_of(study) -> float | None:
    """The study's ``max_peak_transmissibility_db`` (None when absent or switched off)."""
    peak = study.constraints.get("max_peak_transmissibility_db")
    return float(peak) if isinstance(peak, int | float) and not isinstance(peak, bool) else None


def transmissibility(study, design=None, frequency_hz=DEFAULT_FREQUENCY_HZ,
                     floor_amplitude_m=DEFAULT_FLOOR_AMPLITUDES_M, *, values: dict | None = None,
                     models: dict | None = None, branch: str | None = None):
    """The transmissibility of a study's design for harmonic floor motion.

    Parameters
    ----------
    study : Study
        With ``[table]``: the table's answer over points and axes; without: the payload's.
    design : SpringDesign, optional
        Default the study's start design.
    frequency_hz : array_like
        Frequencies, Hz (default 0.5 to 50 Hz, 200 log-spaced).
    floor_amplitude_m : float or array_like
        Floor displacement amplitudes, m (default 1 and 10 um).
    values : dict, optional
        Design-variable and lever values by name (an optimum's ``values``): the table with
        its levers there (a co-designed table).
    models : dict, optional
        ``flow``, ``amplitude_mode``, ``diaphragm`` (default the study's).
    branch : {'upper', 'lower'}, optional
        The payload's stroke where several exist (a study without ``[table]``; default
        ``upper``). Refused for a table: its closure follows the branch reached from small
        amplitudes.

    Returns
    -------
    TableTransmissibility or HarmonicResponse
        A ``[table]`` study's :class:`TableTransmissibility`; otherwise the payload's
        :class:`~isodesign.response.harmonic.HarmonicResponse`.

    Examples
    --------
    >>> import isodesign
    >>> res = isodesign.transmissibility(isodesign.table_study())   # doctest: +SKIP
    >>> res.peaks_frame()                                            # doctest: +SKIP
    """
    from isodesign.optimization.study import Study

    if not isinstance(study, Study):
        raise InputError(f"study: expected a Study (load_study(path) or table_study()), got "
                         f"{type(study).__name__} {study!r:.40}")
    if models is not None and not isinstance(models, dict):
        raise InputError(f"models: expected a dict (flow, amplitude_mode, diaphragm), got "
                         f"{type(models).__name__}")
    if values is not None and not isinstance(values, dict):
        raise InputError(f"values: expected a dict of design values by name, got "
                         f"{type(values).__name__}")
    design = study.start_design() if design is None else design
    m = dict(study.models)
    m.update(models or {})
    if study.table is None:
        from isodesign.response.harmonic import harmonic_response

        return harmonic_response(design, study.payload, frequency_hz, floor_amplitude_m,
                                 flow=m["flow"], amplitude_mode=m["amplitude_mode"],
                                 diaphragm=m["diaphragm"], branch=branch or "upper",
                                 warn=False)
    if branch is not None:
        raise InputError(f"branch: {branch!r} is not available for a study with a [table] "
                         "(each isolator's closure follows the branch reached from small "
                         "amplitudes)")
    table = study.table_at(values)
    peaks = study_closure_peaks(study, design, table, m)
    return table_transmissibility(design, table, frequency_hz, floor_amplitude_m,
                                  flow=m["flow"], amplitude_mode=m["amplitude_mode"],
                                  diaphragm=m["diaphragm"], closure_peaks=peaks,
                                  peak_limit_db=peak_limit_of(study))
