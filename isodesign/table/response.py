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
    RAYLEIGH_NODES,
    equivalent_amplitude,
    velocity_margin_db,
)
from isodesign.response.model import LINEAR_REFERENCE_AMPLITUDE_M, emit_flags, resolve_target
from isodesign.results import ResultDisplay
from isodesign.spring.capillary import STATISTICAL_FLOW_MODELS, statistical_resistance_function
from isodesign.spring.diaphragm import diaphragm_model
from isodesign.spring.equations import air_stiffness, spring_stiffness
from isodesign.table.assembly import AXES, dynamic_stiffness
from isodesign.table.closure import (
    TableDescribing,
    solve_describing_closure,
)
from isodesign.table.floor import TableGrid, table_floor, table_grid
from isodesign.table.model import TableModel, TableOutputs, table_model
from isodesign.table.statistical import TableStatistical, _state_key, solve_table_closure

__all__ = [
    "RIGID_FLOOR_NOTE",
    "TABLE_RANDOM_METHODS",
    "TableBandResponse",
    "TableDistortion",
    "TableStatistical",
    "band_mean_square",
    "solve_table_closure",
    "solve_table_closure_with_distortion",
    "table_band_response",
    "table_distortion",
]

#: What every table result says about its floor model.
RIGID_FLOOR_NOTE = ("rigid floor: the same x, y, z translation under every isolator, axes "
                    "uncorrelated; no floor rotation, no differential floor motion, no "
                    "leveling-valve dynamics")


#: Closures of the table's random response: ``statistical`` (per isolator, the default) and
#: the harmonic closures on each isolator's stroke RMS, as the vertical model's
#: (:data:`isodesign.response.random_input.RANDOM_METHODS`).
TABLE_RANDOM_METHODS = ("statistical", "equivalent_amplitude", "rayleigh")

#: What a table result with the distortion power says.
DISTORTION_NOTE = ("distortion power: each tube's residual of the statistical linearization "
                   "(Hermite orders 3-11 of a translation process) added as a source, it and "
                   "the minor loss's gain at the tube velocity's predicted kurtosis")


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
    distortion_kurtosis : ndarray (n,) or None
        Each tube velocity's kurtosis the distortion power was evaluated at
        (``distortion=True``; ``docs/random-response.md`` 3c), else ``None``.
    closure_gain_ratio : ndarray (n,) or None
        With ``distortion=True``, each minor loss's gain ratio the closure's springs were
        linearized with (their tube velocity is ``closure_tube_velocity_m_s``), else ``None``.
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
    distortion_kurtosis: np.ndarray | None = None
    closure_gain_ratio: np.ndarray | None = None

    @property
    def closure_tube_velocity_m_s(self) -> np.ndarray:
        """The tube velocity RMS each spring is linearized at (m/s): with the distortion, the
        RMS times the minor loss's gain ratio (the NLP's springs, ``table_driver._with_gain``);
        the modes and the continuous peak of this response use it."""
        v = np.asarray(self.tube_velocity_rms_m_s, dtype=float)
        return v if self.closure_gain_ratio is None else v * self.closure_gain_ratio

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
    rayleigh_nodes: int = RAYLEIGH_NODES,
    rtol: float = 1e-10,
    max_iter: int = 100,
    include_gravity: bool = True,
    strict: bool = True,
    warn: bool = True,
    distortion: bool = False,
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
    random_method : {'statistical', 'equivalent_amplitude', 'rayleigh'}
        The closure per isolator: the statistical linearization (default), or a harmonic
        closure on each isolator's stroke RMS (:class:`TableDescribing`; the result's
        ``tube_velocity_rms_m_s`` is NaN, as the vertical model's is None).
    rayleigh_nodes : int
        Nodes of the Rayleigh rule (``random_method='rayleigh'``).
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
    distortion : bool
        Add the tubes' distortion power, the residual of each isolator's statistical
        linearization carried through the table as a pressure-drop source in its tube
        (:func:`table_distortion`, ``docs/random-response.md`` sections 3b and 3c, at each
        tube velocity's predicted kurtosis), to the band response, the strokes and the tube
        velocities, self-consistently. Off by default here, where every model is an
        explicit argument; a study's default is on (``models.distortion``, which
        :func:`isodesign.analyze`, the table NLP and every command apply).

    Returns
    -------
    TableBandResponse
    """
    if random_method not in TABLE_RANDOM_METHODS:
        raise InputError(f"random_method: expected one of {', '.join(TABLE_RANDOM_METHODS)}, "
                         f"got {random_method!r}")
    if random_method == "statistical" and flow not in STATISTICAL_FLOW_MODELS:
        raise InputError(f"flow: {flow!r} has no time-domain law to linearize statistically; "
                         f"valid: {', '.join(STATISTICAL_FLOW_MODELS)} (or "
                         "random_method='equivalent_amplitude')")
    if distortion and random_method != "statistical":
        raise InputError("distortion: the distortion power is the statistical closure's "
                         "residual; valid with random_method='statistical' only")
    rtol = check_positive("rtol", rtol)
    model = table_model(design, table, flow=flow, amplitude_mode=amplitude_mode,
                        diaphragm=diaphragm, include_gravity=include_gravity)  # fmt: skip
    tg = resolve_target(target)
    grid = table_grid(table_floor(floor), bands, target=tg, points_per_band=points_per_band)
    if random_method != "statistical":
        return _describing_response(model, grid, tg.name, random_method, rayleigh_nodes,
                                    rtol, max_iter, strict, warn)
    st = TableStatistical(model, grid)
    flags: list[str] = []
    dist = None
    try:
        if distortion:
            sigma, sigma_u, dist, n_it = solve_table_closure_with_distortion(
                st, rtol=rtol, max_iter=max_iter)  # fmt: skip
        else:
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
    if dist is None:
        return _result(model, grid, tg.name, out, ks, st.kh, np.sqrt(s2), np.sqrt(su2), n_it,
                       flags, warn)  # fmt: skip
    import dataclasses

    from isodesign.response.distortion import kurtosis_flag

    flags += kurtosis_flag(dist.kurtosis_first_order, dist.kurtosis, "isolator ")
    stroke = np.sqrt(s2 + _power(dist.stroke_variance))
    tube = np.sqrt(su2 + _power(dist.tube_velocity_variance))
    res = _result(model, grid, tg.name, out, ks, st.kh, stroke, tube, n_it, flags, warn)
    kurt = "tube velocity kurtosis " + " ".join(f"{k:.2f}" for k in dist.kurtosis)
    return dataclasses.replace(
        res, velocity_rms_m_s=np.sqrt(res.velocity_rms_m_s**2 + _power(dist.band_mean_square)),
        notes=(*res.notes, f"{DISTORTION_NOTE} ({kurt})"),
        distortion_kurtosis=np.asarray(dist.kurtosis, dtype=float),
        closure_gain_ratio=np.asarray(st.gain_ratio, dtype=float).copy())  # fmt: skip



def _power(added):
    """The distortion's added power (a mean square or a variance, >= 0): a response that is
    zero by symmetry (a symmetric table on a vertical floor, in x and y) carries round-off of
    either sign in the distortion's spectrum (|value| ~ 1e-45 m^2/s^2), clipped at zero so the
    total is the linear part (was NaN from the square root of a negative sum). NumPy only."""
    return np.maximum(np.asarray(added, dtype=float), 0.0)

def _describing_response(model, grid, target_name, method, nodes, rtol, max_iter, strict,
                         warn) -> TableBandResponse:
    """The band response with a harmonic closure per isolator (:class:`TableDescribing`)."""
    st = TableDescribing(model, grid, method, nodes)
    flags: list[str] = []
    try:
        sigma, n_it = solve_describing_closure(st, rtol=rtol, max_iter=max_iter)
    except SolverError as exc:
        if strict:
            raise
        warnings.warn(f"table_band_response: {exc}", ModelValidityWarning, stacklevel=3)
        flags.append(str(exc))
        sigma = np.full(model.n_isolators,
                        LINEAR_REFERENCE_AMPLITUDE_M / EQUIVALENT_AMPLITUDE_FACTOR)
        n_it = max_iter
    s2, _, out, ks, _ = st.variances(sigma)
    first, inv = model.unique_isolators()
    seen: dict = {}
    for i in range(model.n_isolators):
        key = (int(first[inv[i]]), float(sigma[i]))
        if key not in seen:
            seen[key] = i
            flags.extend(f"isolator {i + 1}: {line}"
                         for line in st.spring_result(key[0], float(sigma[i]))[0].warnings)
    return _result(model, grid, target_name, out, ks, st.kh, np.sqrt(s2),
                   np.full(model.n_isolators, np.nan), n_it, flags, warn, spring_flags=False)


def band_mean_square(grid, points) -> np.ndarray:
    """Each point's and axis's band mean square velocity from its transmissibilities.

    Parameters
    ----------
    grid : TableGrid
        Its ``band_weight`` ``(3 floor axes, bands, frequencies)``.
    points : ndarray (frequencies, points, 3 outputs, 3 floor axes) of complex
        ``T_p,ba`` (:attr:`TableOutputs.points`).

    Returns
    -------
    ndarray (points, 3, bands)
        ``sum_a sum_f W_a,n(f) |T_p,ba(f)|^2``, m^2/s^2.
    """
    t2 = points.real ** 2 + points.imag ** 2
    return np.einsum("anf,fpba->pbn", grid.band_weight, t2, optimize=True)


def _result(model, grid, target_name, out: TableOutputs, ks, kh, sigma, sigma_u, n_it, flags,
            warn, spring_flags: bool = True) -> TableBandResponse:
    t = out.points
    ms = band_mean_square(grid, t)
    h2 = out.horizontal_strokes.real ** 2 + out.horizontal_strokes.imag ** 2
    hs2 = np.einsum("af,fcna->nc", grid.stroke_weight, h2, optimize=True)
    lin = model.linear_outputs(grid.frequency_hz)
    notes = [*grid.floor.notes, RIGID_FLOOR_NOTE]
    lines = list(flags) + (_spring_flags(model, grid, sigma, sigma_u) if spring_flags else [])
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
    first, inv = model.unique_isolators()
    seen: dict = {}
    for i in range(model.n_isolators):
        d = model.designs[int(first[inv[i]])]
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


@dataclass(frozen=True)
class TableDistortion:
    """The tubes' distortion power through the table (``docs/random-response.md``, 3b).

    Attributes
    ----------
    frequency_hz : ndarray
        Bin centres of the residuals' spectra.
    stroke_variance : ndarray (n,)
        Added vertical stroke variance per isolator, m^2.
    tube_velocity_variance : ndarray (n,)
        Added tube velocity variance per isolator, (m/s)^2.
    band_mean_square : ndarray (k, 3, n_bands)
        Added velocity mean square per instrument point, axis and band, (m/s)^2.
    kurtosis_first_order, kurtosis, gain_ratio, residual_ratio : ndarray (n,)
        Per isolator, as :class:`~isodesign.response.distortion.DistortionPower`'s: the tube
        velocity's first-order and resummed kurtosis, the minor loss's gain and the
        residual's variance at it over the Gaussian ones (docs/random-response.md 3c).
    """

    frequency_hz: np.ndarray
    stroke_variance: np.ndarray
    tube_velocity_variance: np.ndarray
    band_mean_square: np.ndarray
    kurtosis_first_order: np.ndarray | None = None
    kurtosis: np.ndarray | None = None
    gain_ratio: np.ndarray | None = None
    residual_ratio: np.ndarray | None = None


def _bin_parts(st: TableStatistical, omega):
    """The parts of the bins' springs that do not move with the closure's state, computed
    once per :class:`TableStatistical` and bin grid: each distinct design's linear resistance
    (``sigma_u -> C``) and the horizontal elements' stiffness."""
    model = st.model
    cache = st.__dict__.setdefault("_distortion_bins", {})
    key = (omega.size, float(omega[0]), float(omega[-1]))
    if key not in cache:
        c_of: dict = {}
        per = []
        for d in model.designs:
            if d not in c_of:
                c_of[d] = statistical_resistance_function(model.flow, d, omega)
            per.append(c_of[d])
        cache.clear()  # one bin grid per response
        cache[key] = (per, model.horizontal_stiffness(omega))
    return cache[key]


def _springs_at(st: TableStatistical, omega, sigma, sigma_u):
    """Per isolator ``(k, C, network)`` at the bins ``omega`` for the closure's RMS values
    (Cx, Cx, :func:`~isodesign.response.distortion.source_network`'s tuple); isolators of
    one design at one state share one evaluation."""
    from isodesign.response.distortion import source_network

    model = st.model
    c_of, _ = _bin_parts(st, omega)
    seen: dict = {}
    ks, cs, nets = [], [], []
    for i in range(model.n_isolators):
        d = model.designs[i]
        key = (d, float(sigma[i]), float(sigma_u[i]), float(st.gain_ratio[i]))
        if key not in seen:
            c = st.resistance(c_of[i], i, float(sigma_u[i]))
            k_air = air_stiffness(d, omega, c, model.flow)
            k = spring_stiffness(k_air, st.dia.stiffness(omega,
                                                         equivalent_amplitude(float(sigma[i]))))
            seen[key] = (k, c, source_network(d, omega, c.to_complex(), model.flow))
        k, c, net = seen[key]
        ks.append(k)
        cs.append(c)
        nets.append(net)
    return ks, cs, nets


def table_distortion(st: TableStatistical, sigma, sigma_u,
                     group_rel: float | None = None,
                     non_gaussian: bool = True) -> TableDistortion:
    """The tubes' distortion power carried through the table at the closure's state.

    Each isolator's residual ``e_i = (K rho_i/2) s_i^2 (|x_i| x_i - c_1 x_i)`` is a
    pressure-drop source in its tube, uncorrelated with the floor; the residuals of two
    isolators are correlated through their tube velocities (Mehler, cross-spectra from
    :func:`~isodesign.response.distortion.cross_convolutions`). The sources drive the table
    (force ``A_p dp_i / D1_i`` along isolator ``i``'s vertical element, floor held), its
    strokes, its tubes and its instrument points.

    Parameters
    ----------
    st : TableStatistical
    sigma, sigma_u : ndarray (n,)
        The closure's stroke and tube velocity RMS.
    group_rel : float, optional
        Width of the bin groups the response is evaluated on, relative to their frequency
        (default :data:`~isodesign.response.distortion.DISTORTION_GROUP_REL`; 0: every bin).
    non_gaussian : bool
        Scale each residual to its tube velocity's predicted kurtosis (docs/random-response.md
        section 3c; False: Gaussian).

    Returns
    -------
    TableDistortion
    """
    from isodesign.response.distortion import DISTORTION_GROUP_REL, source_network

    if group_rel is None:
        group_rel = DISTORTION_GROUP_REL
    from isodesign.response.distortion import (
        _WEIGHTS,
        DISTORTION_ORDERS,
        DISTORTION_RANGE_FACTOR,
        NON_GAUSSIAN_ORDERS,
        PairTransform,
        band_fractions,
        bin_groups,
        group_extents,
        minor_loss_coefficient,
        table_kurtosis,
        translation_coefficients,
    )

    model, grid = st.model, st.grid
    n, w, geo = model.n_isolators, grid.omega, model.geometry
    last = getattr(st, "_last", None)
    if last is not None and last[0] == _state_key(sigma, sigma_u):
        # the closure's last evaluation (its unexcited axes' zero columns weigh nothing)
        _, out, ks, cs = last
    else:
        ks, cs = st.springs(sigma, sigma_u)
        out = model.outputs(ks, w, st.kh, strokes_only=True)
    sw = grid.stroke_weight  # (3, f)
    # the floor-driven tube velocities, complex, per unit floor displacement (f, n, axis)
    u = np.empty(out.strokes.shape, dtype=complex)
    gains: dict = {}
    for i in range(n):
        # isolators of one spring and state
        key = (model.designs[i], float(sigma_u[i]), float(st.gain_ratio[i]))
        if key not in gains:
            _, g, _, ends = source_network(model.designs[i], w, cs[i].to_complex(), model.flow)
            gains[key] = g * np.sqrt(ends)
        u[:, i, :] = -out.strokes[:, i, :] * gains[key][:, None]
    cross = np.einsum("af,fia,fja->fij", sw, u, u.conj(), optimize=True)  # (f, n, n)
    s2 = np.real(np.einsum("fii->i", cross))
    keep = np.real(np.einsum("fii->f", cross)) > 0
    f_lines, cross = grid.frequency_hz[keep], cross[keep]
    s = np.sqrt(s2)
    coeff = np.array([minor_loss_coefficient(d, model.flow) for d in model.designs])
    amp = coeff * s2  # (K rho/2) s^2 per isolator
    iu, ju = np.triu_indices(n)
    orders = NON_GAUSSIAN_ORDERS if non_gaussian else DISTORTION_ORDERS
    trans = PairTransform(f_lines, cross[:, iu, ju] / (s[iu] * s[ju]))
    fb = trans.f_bins
    top = fb <= DISTORTION_RANGE_FACTOR * f_lines.max()
    f_bins = fb[top]
    # the sources' power summed over groups of bins, the response once per group
    lo, hi = grid.bands.lower_hz, grid.bands.upper_hz
    f_edge = f_bins
    starts, f_bins = bin_groups(f_bins, np.concatenate([lo, hi]), group_rel)
    frac = band_fractions(*group_extents(f_edge, starts, fb[1] - fb[0]), lo, hi)
    p3ij = np.add.reduceat(trans.spectra(np.eye(len(orders))[0], orders)[: top.sum()], starts,
                           axis=0)  # rho_ij^3's spectra on the groups (pairs)
    wb = 2.0 * math.pi * f_bins
    kb, _, net = _springs_at(st, wb, sigma, sigma_u)
    d_flat, _ = dynamic_stiffness(geo, kb, _bin_parts(st, wb)[1], wb)
    dyn = (np.asarray(d_flat.re) + 1j * np.asarray(d_flat.im)).reshape(-1, 6, 6)
    force = np.stack([net[i][0] for i in range(n)], axis=-1)  # (f, n)
    rhs = geo.gz.T[None, :, :] * force[:, None, :]  # (f, 6, n): the sources' generalized forces
    q = np.linalg.solve(dyn, rhs)  # (f, 6, n_src)
    x = -np.einsum("ik,fks->fis", geo.gz, q)  # compression of isolator i per source s
    ut = np.stack([net[i][1] for i in range(n)], axis=-1)[:, :, None] * x
    ut[:, np.arange(n), np.arange(n)] += np.stack([net[i][2] for i in range(n)], axis=-1)
    ends = np.stack([net[i][3] for i in range(n)], axis=-1)
    kurt1, kurt, gain, res, beta = table_kurtosis(p3ij, ut, amp, s, iu, ju, non_gaussian)
    # the residuals' cross-spectra: sum_k k! a_k,i a_k,j (rho_ij^k) (translation processes)
    a_k = translation_coefficients(kurt, orders, beta)  # (n, orders)
    fact = np.array([math.factorial(k) for k in orders], dtype=float)
    w_pair = fact * a_k[iu] * a_k[ju]  # (pairs, orders)
    res = (fact * a_k * a_k).sum(axis=1) / sum(_WEIGHTS.values())
    g_e = np.empty((f_bins.size, n, n), dtype=complex)
    pij = np.add.reduceat(trans.spectra(w_pair, orders)[: top.sum()], starts, axis=0)
    g_e[:, iu, ju] = (amp[iu] * amp[ju]) * pij
    g_e[:, ju, iu] = np.conj(g_e[:, iu, ju])

    def power(h):  # diag(H G_e H^H) per frequency: (f, r)
        return np.real(np.einsum("fri,fij,frj->fr", h, g_e, h.conj(), optimize=False))

    ds2 = power(x).sum(axis=0)
    dsu2 = (power(ut) * ends).sum(axis=0)
    pts = np.einsum("pbk,fks->fpbs", geo.points, q) * (1j * wb)[:, None, None, None]
    k_pts, _, _ = geo.points.shape
    pv = power(pts.reshape(wb.size, 3 * k_pts, n)).reshape(wb.size, k_pts, 3)
    band = np.einsum("gpa,gb->pab", pv, frac)  # edge groups shared by their overlap
    return TableDistortion(frequency_hz=f_bins, stroke_variance=ds2,
                           tube_velocity_variance=dsu2, band_mean_square=band,
                           kurtosis_first_order=kurt1, kurtosis=kurt, gain_ratio=gain,
                           residual_ratio=res)


class _WithOffset:
    """A :class:`TableStatistical` whose variances carry the distortion's (the closure solved
    again with it)."""

    def __init__(self, st: TableStatistical, ds2, dsu2):
        self.st, self.model, self.grid = st, st.model, st.grid
        self.ds2, self.dsu2 = np.asarray(ds2), np.asarray(dsu2)

    def variances(self, sigma, sigma_u, *, strokes_only: bool = False):
        s2, su2, out, ks, cs = self.st.variances(sigma, sigma_u, strokes_only=strokes_only)
        return s2 + self.ds2, su2 + self.dsu2, out, ks, cs


def solve_table_closure_with_distortion(st: TableStatistical, *, rtol: float = 1e-10,
                                        max_iter: int = 100, non_gaussian: bool = True,
                                        first_rtol: float | None = None,
                                        first: list | None = None):
    """The per-isolator closure with the tubes' distortion power, self-consistently.

    As the vertical payload's (``docs/random-response.md`` 3a): the distortion at the plain
    closure's state, the closure solved again with its variances added, the distortion at
    the new state.

    Parameters
    ----------
    st : TableStatistical
        The linearization on its grid.
    rtol : float
        Closure tolerance on ``ln sigma``.
    max_iter : int
        Closure iterations.
    non_gaussian : bool
        The residuals and the minor loss's gains at the tube velocities' predicted kurtosis
        (docs/random-response.md 3c; False: Gaussian).
    first_rtol : float, optional
        The plain closure's tolerance (default: ``DISTORTION_FIRST_RTOL`` or ``rtol``).
    first : list, optional
        Appended with the plain closure's :class:`TableDistortion` (the second's offsets).

    Returns
    -------
    tuple
        ``(sigma, sigma_u, TableDistortion, evaluations)``: the RMS values include the
        distortion's.
    """
    from isodesign.response.distortion import DISTORTION_FIRST_RTOL

    record: list = []
    # the plain closure only as close as the distortion evaluated there needs (the second
    # closure is solved to rtol; docs/random-response.md 3a)
    tol0 = max(rtol, DISTORTION_FIRST_RTOL) if non_gaussian else rtol
    tol0 = tol0 if first_rtol is None else first_rtol
    sigma, sigma_u, n_it = solve_table_closure(st, rtol=tol0, max_iter=max_iter, record=record)
    dist = table_distortion(st, sigma, sigma_u, non_gaussian=non_gaussian)
    if first is not None:
        first.append(dist)
    # the second closure's map is the first's with the offset added to its variances,
    # g'(x) = ln(exp(2 g(x)) + offset) / 2, exactly: the first solve's evaluations are the
    # second's too, and its mixing starts from them (at the plain solution) at no cost;
    # not so when the non-Gaussian gain moves the map (then from one fixed-point step on)
    off = np.concatenate([dist.stroke_variance, dist.tube_velocity_variance])
    hist = [(x, 0.5 * np.log(np.exp(2.0 * gx) + off)) for x, gx in record]
    if np.any(dist.gain_ratio != 1.0):
        st.gain_ratio = np.asarray(dist.gain_ratio, dtype=float).copy()
        st._last = None
        hist = []
    # without them (a z DOF closure): start one fixed-point step on
    start = (np.sqrt(sigma**2 + _power(dist.stroke_variance)),
             np.sqrt(sigma_u**2 + _power(dist.tube_velocity_variance)))
    sigma, sigma_u, n2 = solve_table_closure(
        _WithOffset(st, dist.stroke_variance, dist.tube_velocity_variance), rtol=rtol,
        max_iter=max_iter, start=start, history=hist or None)  # fmt: skip
    dist = table_distortion(st, sigma, sigma_u, non_gaussian=non_gaussian)
    return sigma, sigma_u, dist, n_it + n2
