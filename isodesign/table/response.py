"""Band response of the table in three axes, with the random closure per isolator.

The floor moves in x, y and z (uncorrelated, :mod:`isodesign.table.floor`). Each
isolator's vertical spring is linearized statistically like the 1-DOF payload's
(docs/random-response.md): its tube's nonlinear pressure drop becomes the
Gaussian-equivalent resistance at its own tube-velocity RMS ``sigma_u,i`` and its diaphragm
is evaluated at ``A* = 1.880 sigma_i`` of its own stroke RMS. Each stroke is a combination
of the table's six motions, so the ``2n`` RMS values are solved together (docs/table.md,
section 5)::

    sigma_i^2   = sum_a sum_j w_a[j] |S_ia(f_j)|^2
    sigma_u,i^2 = sum_a sum_j w_a[j] |S_ia(f_j)|^2 |U/X|_i^2(f_j)

with ``S_ia`` the stroke of isolator ``i`` per unit floor displacement in axis ``a`` and
``w_a`` that axis' stroke weights; a fixed point in ``ln sigma`` accelerated by Anderson
mixing. Isolators with equal p0 and equal RMS values share one spring evaluation
(symmetry). The band mean square of point ``p``, axis ``b`` is
``sum_a band_weight_a @ |T_p,ba|^2``.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from isodesign.errors import InputError, ModelValidityWarning, SolverError, check_positive
from isodesign.response.linearization import (
    EQUIVALENT_AMPLITUDE_FACTOR,
    equivalent_amplitude,
    velocity_margin_db,
)
from isodesign.response.model import LINEAR_REFERENCE_AMPLITUDE_M, emit_flags, resolve_target
from isodesign.results import ResultDisplay
from isodesign.spring.capillary import STATISTICAL_FLOW_MODELS, statistical_resistance_function
from isodesign.spring.diaphragm import diaphragm_model
from isodesign.spring.equations import air_stiffness, spring_stiffness, tube_velocity_gain2
from isodesign.table.assembly import AXES
from isodesign.table.floor import TableGrid, table_floor, table_grid
from isodesign.table.model import TableModel, TableOutputs, table_model

__all__ = ["RIGID_FLOOR_NOTE", "TableBandResponse", "TableStatistical", "solve_table_closure",
           "table_band_response"]

#: What every table result says about its floor model.
RIGID_FLOOR_NOTE = ("rigid floor: the same x, y, z translation under every isolator, axes "
                    "uncorrelated; no floor rotation, no differential floor motion, no "
                    "leveling-valve dynamics")


class TableStatistical:
    """The statistical linearization of every isolator on a :class:`TableGrid` (NumPy).

    Parameters
    ----------
    model : TableModel
    grid : TableGrid
    """

    def __init__(self, model: TableModel, grid: TableGrid):
        self.model, self.grid = model, grid
        self.dia = diaphragm_model(model.diaphragm)
        w = grid.omega
        self.first, self.inv = model.unique_isolators()
        self.c_of = {int(i): statistical_resistance_function(model.flow, model.designs[i], w)
                     for i in self.first}  # fmt: skip
        self.kh = model.horizontal_stiffness(w)

    def springs(self, sigma, sigma_u):
        """Per isolator ``(k, C)`` (Cx on the grid) at the RMS values ``sigma``, ``sigma_u``.

        Parameters
        ----------
        sigma, sigma_u : ndarray (n,)
            Stroke and tube-velocity RMS per isolator (m, m/s).
        """
        w = self.grid.omega
        cache: dict = {}
        ks, cs = [], []
        for i in range(self.model.n_isolators):
            rep = int(self.first[self.inv[i]])
            key = (rep, float(sigma[i]), float(sigma_u[i]))
            if key not in cache:
                c = self.c_of[rep](float(sigma_u[i]))
                k_air = air_stiffness(self.model.designs[rep], w, c, self.model.flow)
                k_d = self.dia.stiffness(w, equivalent_amplitude(float(sigma[i])))
                cache[key] = (spring_stiffness(k_air, k_d), c, k_air, k_d)
            k, c, _, _ = cache[key]
            ks.append(k)
            cs.append(c)
        return ks, cs

    def variances(self, sigma, sigma_u, *, strokes_only: bool = False):
        """``(sigma^2, sigma_u^2, outputs, k, C)`` produced at ``(sigma, sigma_u)``.

        Parameters
        ----------
        sigma, sigma_u : ndarray (n,)
            Stroke and tube-velocity RMS per isolator.
        strokes_only : bool
            Outputs with the strokes only (the closure's iterations).
        """
        ks, cs = self.springs(sigma, sigma_u)
        out = self.model.outputs(ks, self.grid.omega, self.kh, strokes_only=strokes_only)
        a2 = out.strokes.real ** 2 + out.strokes.imag ** 2  # (f, n, 3)
        sw = self.grid.stroke_weight  # (3, f)
        s2 = np.einsum("fna,af->n", a2, sw, optimize=True)
        su2 = np.empty_like(s2)
        for i in range(self.model.n_isolators):
            g2 = np.asarray(tube_velocity_gain2(self.model.designs[i], self.grid.omega, cs[i],
                                                self.model.flow))
            su2[i] = float(np.sum(sw.T * a2[:, i, :] * g2[:, None]))
        return s2, su2, out, ks, cs


def _anderson(g, x0: np.ndarray, tol: float, max_iter: int, depth: int = 6):
    """Fixed point ``x = g(x)`` by Anderson mixing; returns ``(x, evaluations, residual)``."""
    x = x0.copy()
    gx = g(x)
    n_eval = 1
    xs, gs = [x], [gx]
    for _ in range(max_iter):
        f = gx - x
        res = float(np.max(np.abs(f)))
        if res <= tol:
            return x, n_eval, res
        if len(xs) >= 2:
            hist = zip(xs[-depth - 1:], gs[-depth - 1:], strict=True)
            fs = np.array([gi - xi for xi, gi in hist])
            df = np.diff(fs, axis=0).T
            dg = np.diff(np.array(gs[-depth - 1:]), axis=0).T
            gamma = np.linalg.lstsq(df, f, rcond=None)[0]
            x_new = gx - dg @ gamma
        else:
            x_new = gx
        step = np.clip(x_new - x, -2.0, 2.0)
        x = x + step
        if not np.all(np.isfinite(x)):
            break
        gx = g(x)
        n_eval += 1
        xs.append(x)
        gs.append(gx)
    f = gx - x
    return x, n_eval, float(np.max(np.abs(f)))


def solve_table_closure(st: TableStatistical, *, rtol: float = 1e-10, max_iter: int = 100):
    """Solve the per-isolator statistical closure; ``(sigma, sigma_u, evaluations)``.

    Parameters
    ----------
    st : TableStatistical
        The linearization on its grid.
    rtol : float
        Tolerance on ``max |ln(sigma_new / sigma)|`` over the ``2n`` RMS values.
    max_iter : int
        Iterations of the fixed point before the Newton (hybrid Powell) fallback.

    Raises
    ------
    SolverError
        No convergence.
    """
    n = st.model.n_isolators
    sigma0 = np.full(n, LINEAR_REFERENCE_AMPLITUDE_M / EQUIVALENT_AMPLITUDE_FACTOR)
    s2, su2, _, _, _ = st.variances(sigma0, np.full(n, 1e-9), strokes_only=True)
    if not np.all(s2 > 0):
        raise InputError("floor: the spectrum carries no motion (PSD zero)")
    x0 = 0.5 * np.log(np.concatenate([s2, np.maximum(su2, 1e-300)]))

    def g(x):
        e = np.exp(x)
        a, b, _, _, _ = st.variances(e[:n], e[n:], strokes_only=True)
        return 0.5 * np.log(np.concatenate([a, np.maximum(b, 1e-300)]))

    x, n_eval, res = _anderson(g, x0, rtol, max_iter)
    if not res <= rtol:
        from scipy.optimize import root

        sol = root(lambda z: g(z) - z, x if np.all(np.isfinite(x)) else x0, method="hybr",
                   options={"xtol": 1e-14})  # fmt: skip
        n_eval += int(sol.nfev)
        res = float(np.max(np.abs(g(sol.x) - sol.x)))
        if not res <= max(rtol, 1e-9):
            raise SolverError(f"table closure did not converge: max |ln(sigma_new/sigma)| = "
                              f"{res:.3g} > rtol = {rtol:g} after {n_eval} evaluations")
        x = sol.x
    e = np.exp(x)
    return e[:n], e[n:], n_eval


@dataclass(frozen=True, eq=False, repr=False)
class TableBandResponse(ResultDisplay):
    """Band response of a table in three axes, at each instrument point, and its verdict.

    Attributes
    ----------
    grid : TableGrid
    velocity_rms_m_s : ndarray (k, 3, n_bands)
        Band RMS velocity ``[point, axis (x, y, z), band]``.
    floor_velocity_rms_m_s : ndarray (3, n_bands)
    limit_velocity_rms_m_s : ndarray (n_bands,)
    stroke_rms_m : ndarray (n,)
        Vertical stroke RMS of each isolator at the closure.
    tube_velocity_rms_m_s : ndarray (n,)
    horizontal_stroke_rms_m : ndarray (n, 2)
        x and y relative motion RMS at each elastic centre.
    transmissibility : ndarray (n_freq, k, 3, 3) complex
        ``[f, point, output axis, floor axis]`` at the closure.
    transmissibility_linear : ndarray (n_freq, k, 3, 3) complex
        The same with every spring at 1 um (linear regime).
    k_vertical : ndarray (n, n_freq) complex
        Each isolator's vertical ``k*`` at the closure.
    k_horizontal : ndarray (n, n_freq) complex
    model : TableModel
    iterations : int
    point_names : tuple of str
    target_name : str
    notes : tuple of str
        Assumptions (floor axes) and what the model leaves out.
    flags : tuple of str
        Validity flags.
    """

    grid: TableGrid
    velocity_rms_m_s: np.ndarray
    floor_velocity_rms_m_s: np.ndarray
    limit_velocity_rms_m_s: np.ndarray
    stroke_rms_m: np.ndarray
    tube_velocity_rms_m_s: np.ndarray
    horizontal_stroke_rms_m: np.ndarray
    transmissibility: np.ndarray
    transmissibility_linear: np.ndarray
    k_vertical: np.ndarray
    k_horizontal: np.ndarray
    model: TableModel
    iterations: int
    point_names: tuple
    target_name: str
    notes: tuple = ()
    flags: tuple = ()

    @property
    def bands(self):
        """The one-third-octave bands."""
        return self.grid.bands

    @property
    def margin_db(self) -> np.ndarray:
        """``20 log10(limit / velocity)`` per point, axis and band (positive: below)."""
        return velocity_margin_db(self.limit_velocity_rms_m_s, self.velocity_rms_m_s)

    @property
    def passes(self) -> bool:
        """Every point, axis and band meets the target."""
        return bool(np.all(self.velocity_rms_m_s <= self.limit_velocity_rms_m_s))

    @property
    def worst(self) -> tuple[str, str, str, float]:
        """``(point, axis, band label, margin dB)`` of the smallest margin."""
        m = self.margin_db
        p, a, b = np.unravel_index(int(np.argmin(m)), m.shape)
        return self.point_names[p], AXES[a], self.bands.labels[b], float(m[p, a, b])

    @property
    def worst_margin_db(self) -> float:
        """Smallest margin over points, axes and bands, dB."""
        return float(np.min(self.margin_db))

    def peak_transmissibility_db(self) -> np.ndarray:
        """Largest ``|T_p,aa|`` (dB) over the grid, per point and axis, shape (k, 3)."""
        diag = np.abs(np.diagonal(self.transmissibility, axis1=2, axis2=3))  # (f, k, 3)
        return 20.0 * np.log10(diag.max(axis=0))

    def axis_margin_db(self) -> np.ndarray:
        """Worst margin per axis (over points and bands), shape (3,)."""
        return self.margin_db.min(axis=(0, 2))

    def verdict(self) -> str:
        """One line: PASS/FAIL, worst point, axis and band, margin."""
        m = self.margin_db
        nfail = int(np.sum(m < 0))
        head = (f"PASS: {self.target_name} met at {len(self.point_names)} point(s) x 3 axes x "
                f"{len(self.bands)} bands" if self.passes else
                f"FAIL: {self.target_name} exceeded in {nfail} of {m.size} point-axis-bands")
        p, a, b, w = self.worst
        return f"{head}; worst {p} {a} {b} Hz, margin {w:+.2f} dB"

    def to_frame(self):
        """One row per (point, axis, band): floor, velocity, limit, margin, pass."""
        import pandas as pd

        rows = []
        bands = self.bands
        for p, name in enumerate(self.point_names):
            for a, ax in enumerate(AXES):
                for b in range(len(bands)):
                    v = self.velocity_rms_m_s[p, a, b]
                    lim = self.limit_velocity_rms_m_s[b]
                    rows.append((name, ax, bands.labels[b], float(bands.nominal_hz[b]),
                                 self.floor_velocity_rms_m_s[a, b], v, lim,
                                 20.0 * math.log10(lim / v), bool(v <= lim)))  # fmt: skip
        df = pd.DataFrame(rows, columns=["point", "axis", "band", "band_hz",
                                         "floor_velocity_rms_m_s", "velocity_rms_m_s",
                                         "limit_velocity_rms_m_s", "margin_db", "passes"])
        df.attrs.update(target=self.target_name, verdict=self.verdict(),
                        floor=", ".join(f"{a}: {n}" for a, n in
                                        zip(AXES, self.grid.floor.names, strict=True)),
                        notes="; ".join(self.notes))  # fmt: skip
        return df

    def transmissibility_frame(self):
        """The transmissibility arrays, labelled: one row per frequency, point, floor axis
        and point axis.

        Returns
        -------
        pandas.DataFrame
            ``frequency_hz``, ``point``, ``axis_in`` (the floor's motion), ``axis_out`` (the
            point's), ``transmissibility_abs``, ``transmissibility_db``, ``phase_deg`` at the
            closure and ``transmissibility_linear_db`` (every spring at 1 um); see
            :func:`isodesign.table.frames.transmissibility_frame`.
        """
        from isodesign.table.frames import transmissibility_frame

        return transmissibility_frame(self.grid.frequency_hz, self.transmissibility,
                                      self.point_names, linear=self.transmissibility_linear)

    def isolator_frame(self):
        """One row per isolator: group, load, p0, stroke and tube-velocity RMS."""
        df = self.model.leveling.to_frame()
        df["stroke_rms_m"] = self.stroke_rms_m
        df["tube_velocity_rms_m_s"] = self.tube_velocity_rms_m_s
        df["horizontal_stroke_rms_x_m"] = self.horizontal_stroke_rms_m[:, 0]
        df["horizontal_stroke_rms_y_m"] = self.horizontal_stroke_rms_m[:, 1]
        return df

    def _summary_items(self) -> list[tuple[str, str]]:
        p, a, b, w = self.worst
        return [
            ("", "PASS" if self.passes else "FAIL"),
            ("worst", f"{p} {a} {b} Hz {w:+.2f} dB"),
            ("worst per axis", ", ".join(f"{ax} {m:+.2f} dB" for ax, m in
                                         zip(AXES, self.axis_margin_db(), strict=True))),
            ("floor", ", ".join(f"{ax}: {n}" for ax, n in
                                zip(AXES, self.grid.floor.names, strict=True))),
            ("limit", self.target_name),
            ("stroke RMS", ", ".join(f"{s * 1e6:.3g}" for s in self.stroke_rms_m) + " um"),
        ]  # fmt: skip

    def _display_frame(self):
        df = self.to_frame()
        return df.groupby(["point", "axis"], sort=False)["margin_db"].min().reset_index()

    def plot(self, ax=None):
        """Band RMS velocity per axis (one panel each) at every point, with the limit.

        Parameters
        ----------
        ax : sequence of 3 matplotlib Axes, optional
            Default: a new figure.

        Returns
        -------
        matplotlib.figure.Figure
        """
        from isodesign.table.plots import table_bands_figure

        return table_bands_figure(self, axes=ax)


def table_band_response(
    design,
    table,
    floor,
    target,
    *,
    bands=None,
    points_per_band: int = 50,
    flow: str = "quasi_steady",
    amplitude_mode: str = "self_consistent",
    diaphragm="viscoelastic",
    random_method: str = "statistical",
    rtol: float = 1e-10,
    max_iter: int = 100,
    include_gravity: bool = True,
    strict: bool = True,
    warn: bool = True,
) -> TableBandResponse:
    """One-third-octave band response of a rigid table on n isolators, in three axes.

    Parameters
    ----------
    design : SpringDesign
        The isolators' spring (identical hardware; p0 from three-valve leveling).
    table : Table
    floor : TableFloor, FloorSpectrum, str or path
        The floor per axis (:func:`~isodesign.table.floor.table_floor`; one floor applies to
        every axis, and the result says so).
    target : str, CriterionCurve or path
        The instrument's criterion, applied in every axis at every instrument point.
    bands : Bands or (f_min_hz, f_max_hz), optional
    points_per_band : int
    flow, amplitude_mode, diaphragm : str
        Spring models (the vertical diaphragm may be any model object).
    random_method : {'statistical'}
        The closure (statistical linearization per isolator).
    rtol : float
        Closure tolerance on ``ln sigma``.
    max_iter : int
        Closure iterations.
    include_gravity : bool
        The overturning term (default on).
    strict : bool
        Raise if the closure fails (else return the linear-regime response, flagged).
    warn : bool
        Emit one ModelValidityWarning with the validity flags and notes.

    Returns
    -------
    TableBandResponse
    """
    if random_method != "statistical":
        raise InputError(f"random_method: the table response supports 'statistical', got "
                         f"{random_method!r}")
    if flow not in STATISTICAL_FLOW_MODELS:
        raise InputError(f"flow: {flow!r} has no time-domain law to linearize statistically; "
                         f"valid: {', '.join(STATISTICAL_FLOW_MODELS)}")
    rtol = check_positive("rtol", rtol)
    model = table_model(design, table, flow=flow, amplitude_mode=amplitude_mode,
                        diaphragm=diaphragm, include_gravity=include_gravity)  # fmt: skip
    tg = resolve_target(target)
    grid = table_grid(table_floor(floor), bands, target=tg, points_per_band=points_per_band)
    st = TableStatistical(model, grid)
    flags: list[str] = []
    try:
        sigma, sigma_u, n_it = solve_table_closure(st, rtol=rtol, max_iter=max_iter)
    except SolverError as exc:
        if strict:
            raise
        warnings.warn(f"table_band_response: {exc}", ModelValidityWarning, stacklevel=2)
        flags.append(str(exc))
        n = model.n_isolators
        sigma = np.full(n, LINEAR_REFERENCE_AMPLITUDE_M / EQUIVALENT_AMPLITUDE_FACTOR)
        sigma_u, n_it = np.full(n, 1e-9), max_iter
    s2, su2, out, ks, _ = st.variances(sigma, sigma_u)
    return _result(model, grid, tg.name, out, ks, st.kh, np.sqrt(s2), np.sqrt(su2), n_it,
                   flags, warn)  # fmt: skip


def _result(model, grid, target_name, out: TableOutputs, ks, kh, sigma, sigma_u, n_it, flags,
            warn) -> TableBandResponse:
    bw = grid.band_weight
    t = out.points
    t2 = t.real ** 2 + t.imag ** 2
    ms = np.einsum("anf,fpba->pbn", bw, t2, optimize=True)
    h2 = out.horizontal_strokes.real ** 2 + out.horizontal_strokes.imag ** 2
    hs2 = np.einsum("af,fcna->nc", grid.stroke_weight, h2, optimize=True)
    lin = model.linear_outputs(grid.frequency_hz)
    notes = [*grid.floor.notes, RIGID_FLOOR_NOTE]
    lines = list(flags) + _spring_flags(model, grid, sigma, sigma_u)
    res = TableBandResponse(
        grid=grid, velocity_rms_m_s=np.sqrt(ms), floor_velocity_rms_m_s=grid.floor_velocity_rms_m_s,
        limit_velocity_rms_m_s=grid.limit_velocity_m_s, stroke_rms_m=np.asarray(sigma),
        tube_velocity_rms_m_s=np.asarray(sigma_u), horizontal_stroke_rms_m=np.sqrt(hs2),
        transmissibility=t, transmissibility_linear=lin.points,
        k_vertical=np.stack([k.to_complex() for k in ks]),
        k_horizontal=np.stack([np.broadcast_to(k.to_complex(), grid.frequency_hz.shape)
                               for k in kh]),
        model=model, iterations=int(n_it), point_names=model.table.point_names,
        target_name=target_name, notes=tuple(notes), flags=tuple(lines),
    )  # fmt: skip
    emit_flags(lines, "table_band_response", warn)
    return res


def _spring_flags(model, grid, sigma, sigma_u) -> list[str]:
    """Validity flags of each distinct isolator's spring at the closure."""
    from isodesign.spring.diagnostics import evaluate_diagnostics
    from isodesign.spring.stiffness import StiffnessResult

    f, w = grid.frequency_hz, grid.omega
    dia = diaphragm_model(model.diaphragm)
    out: list[str] = []
    seen: dict = {}
    for i in range(model.n_isolators):
        d = model.designs[i]
        key = (float(d.pressure_pa), float(sigma[i]), float(sigma_u[i]))
        if key in seen:
            continue
        seen[key] = i
        c = statistical_resistance_function(model.flow, d, w)(float(sigma_u[i]))
        k_air = air_stiffness(d, w, c, model.flow)
        amp = equivalent_amplitude(float(sigma[i]))
        k_d = dia.stiffness(w, amp)
        k = spring_stiffness(k_air, k_d).to_complex()
        diag = evaluate_diagnostics(model.flow, d, w, np.full(f.shape, amp),
                                    np.full(f.shape, math.sqrt(2.0) * float(sigma_u[i])), c,
                                    k_air.to_complex(), k, dia, "self_consistent")  # fmt: skip
        res = StiffnessResult(frequency_hz=f, amplitude_m=np.full(f.shape, amp), k=k,
                              k_air=k_air.to_complex(),
                              k_diaphragm=np.broadcast_to(k_d.to_complex(), f.shape),
                              diagnostics=diag, flow=model.flow, amplitude_mode="statistical",
                              diaphragm=dia.name, design=d)  # fmt: skip
        out.extend(f"isolator {i + 1}: {line}" for line in res.warnings)
    return out
