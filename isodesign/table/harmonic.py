"""Response of the table to harmonic floor motion, closed self-consistently per isolator.

A sinusoidal floor translation ``u_f = X_f e`` (``e`` a unit direction in x, y, z) at
frequency ``f``. Each isolator's spring is the harmonic describing function ``k*(X_i, f)``
at its own stroke amplitude ``X_i`` (the spring model's self-consistent tube flow), and the
``n`` amplitudes solve together (docs/table.md, section 5)::

    X_i = |S_i(f; X_1..X_n) . e| X_f          (S_i: stroke of isolator i per floor motion)

a fixed point in ``ln X`` from the linear-regime strokes, accelerated by Anderson mixing and
vectorized over the frequencies. The branch is the one reached from small amplitudes (no
enumeration of coexisting branches, unlike the 1-DOF
:func:`~isodesign.response.harmonic.harmonic_response`); a point that does not converge is
flagged, never returned as converged.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from isodesign.errors import InputError, check_positive
from isodesign.response.model import TWO_PI
from isodesign.results import ResultDisplay
from isodesign.table.assembly import AXES
from isodesign.table.model import TableModel, table_model

__all__ = ["TableHarmonicResponse", "table_harmonic_response"]


@dataclass(frozen=True, eq=False, repr=False)
class TableHarmonicResponse(ResultDisplay):
    """Harmonic response of a table: instrument points and strokes per frequency.

    Attributes
    ----------
    frequency_hz : ndarray (n_freq,)
    floor_amplitude_m : float
    direction : ndarray (3,)
        Unit direction of the floor motion.
    point_amplitude_m : ndarray (n_freq, k, 3)
        Displacement amplitude of each instrument point per axis.
    transmissibility : ndarray (n_freq, k, 3) complex
        Point motion per floor amplitude (complex, per axis).
    stroke_amplitude_m : ndarray (n_freq, n)
        Each isolator's self-consistent vertical stroke amplitude.
    converged : ndarray of bool (n_freq,)
    iterations : int
    model : TableModel
    """

    frequency_hz: np.ndarray
    floor_amplitude_m: float
    direction: np.ndarray
    point_amplitude_m: np.ndarray
    transmissibility: np.ndarray
    stroke_amplitude_m: np.ndarray
    converged: np.ndarray
    iterations: int
    model: TableModel

    @property
    def direction_name(self) -> str:
        """The floor motion's name: ``x``, ``y``, ``z``, or its direction ``(0.6, 0, 0.8)``."""
        for a, e in zip(AXES, np.eye(3), strict=True):
            if np.allclose(self.direction, e):
                return a
        return "(" + ", ".join(f"{v:.3g}" for v in self.direction) + ")"

    def to_frame(self):
        """One row per frequency, point and axis of the point's motion.

        Returns
        -------
        pandas.DataFrame
            ``frequency_hz``, ``point``, ``axis_in`` (the floor motion's direction,
            :attr:`direction_name`), ``axis_out``, ``transmissibility_abs``,
            ``transmissibility_db``, ``phase_deg`` (:func:`~isodesign.table.frames.
            transmissibility_frame`), then ``amplitude_m`` (the point's displacement
            amplitude) and ``converged``.
        """
        from isodesign.table.frames import transmissibility_frame

        df = transmissibility_frame(self.frequency_hz, self.transmissibility[..., None],
                                    self.model.table.point_names,
                                    axes_in=(self.direction_name,))
        df["amplitude_m"] = self.point_amplitude_m.ravel()
        df["converged"] = np.repeat(self.converged, self.transmissibility[0].size)
        return df

    def plot(self, ax=None):
        """|T| (dB) of every instrument point and axis against frequency.

        Parameters
        ----------
        ax : matplotlib Axes, optional

        Returns
        -------
        matplotlib.figure.Figure
        """
        from isodesign.table.plots import table_harmonic_figure

        return table_harmonic_figure(self, ax=ax)

    def _summary_items(self) -> list[tuple[str, str]]:
        return [("frequencies", str(self.frequency_hz.size)),
                ("floor", f"{self.floor_amplitude_m:g} m along {self.direction.round(3)}"),
                ("converged", f"{int(self.converged.sum())} of {self.converged.size}")]


def table_harmonic_response(design, table, frequency_hz, floor_amplitude_m, direction="z", *,
                            flow: str = "quasi_steady",
                            amplitude_mode: str = "self_consistent",
                            diaphragm="viscoelastic", rtol: float = 1e-10,
                            max_iter: int = 200) -> TableHarmonicResponse:
    """Harmonic floor motion on a table; each isolator closed on its own stroke amplitude.

    Parameters
    ----------
    design : SpringDesign
        The isolators' spring (p0 from the leveling).
    table : Table
    frequency_hz : array_like
        Frequencies, Hz.
    floor_amplitude_m : float
        Floor displacement amplitude, m.
    direction : {'x', 'y', 'z'} or sequence of 3 float
        The floor motion's direction (normalized).
    flow, amplitude_mode, diaphragm : str
        Spring models.
    rtol : float
        Tolerance on ``max |ln(X_new / X)|``.
    max_iter : int
        Iterations.

    Returns
    -------
    TableHarmonicResponse
    """
    f = check_positive("frequency_hz", frequency_hz, unit="Hz", allow_array=True)
    f = np.atleast_1d(f)
    xf = check_positive("floor_amplitude_m", floor_amplitude_m, unit="m")
    if isinstance(direction, str):
        if direction not in AXES:
            raise InputError(f"direction: expected x, y, z or 3 numbers, got {direction!r}")
        e = np.eye(3)[AXES.index(direction)]
    else:
        e = np.asarray(direction, float)
        if e.shape != (3,) or not np.all(np.isfinite(e)) or not np.linalg.norm(e) > 0:
            raise InputError("direction: expected 3 finite numbers, not all zero")
        e = e / np.linalg.norm(e)
    model = table_model(design, table, flow=flow, amplitude_mode=amplitude_mode,
                        diaphragm=diaphragm)
    w = TWO_PI * f
    kh = model.horizontal_stiffness(w)
    n = model.n_isolators

    def strokes(amp):  # amp (nf, n) -> complex strokes (nf, n) for the floor motion e X_f
        kv = []
        for i in range(n):
            kv.append(model.spring(i).k(f, amp[:, i], pairwise=True))
        out = model.outputs(kv, w, kh, strokes_only=True)
        return out.strokes @ e * xf, kv

    s0, _ = strokes(np.full((f.size, n), 1e-6))
    x = np.log(np.maximum(np.abs(s0), 1e-15)).ravel()

    def g(xv):
        s, _ = strokes(np.exp(xv.reshape(f.size, n)))
        return np.log(np.maximum(np.abs(s), 1e-15)).ravel()

    from isodesign.table.closure import anderson as _anderson

    x, n_it, _ = _anderson(g, x, rtol, max_iter)
    amp = np.exp(x.reshape(f.size, n))
    s, kv = strokes(amp)
    res = np.abs(np.log(np.maximum(np.abs(s), 1e-15)) - np.log(amp))
    conv = np.all(res <= max(rtol, 1e-9) * 10, axis=1)
    out = model.outputs(kv, w, kh)
    t = out.points @ e  # (nf, k, 3)
    return TableHarmonicResponse(frequency_hz=f, floor_amplitude_m=xf, direction=e,
                                 point_amplitude_m=np.abs(t) * xf, transmissibility=t,
                                 stroke_amplitude_m=amp, converged=conv, iterations=n_it,
                                 model=model)
