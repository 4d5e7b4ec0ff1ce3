"""Diaphragm identification from rig data, the paper's way (Section 3.2), as a convex fit.

1. The air's share is subtracted from the measured total (Eq. 42): with the capillary blocked
   (``single_chamber``) the air is the constant ``k_s`` of Eq. 40; for the dual-chamber spring
   it is the air model ``k_d*`` of Eq. 38 (:func:`isodesign.spring.stiffness.complex_stiffness`
   with ``diaphragm="none"``, self-consistent flow amplitude by default).
2. The rest, ``k_D*(w, X)``, is fitted by a :class:`~isodesign.spring.diaphragm.FittedDiaphragm`:
   a generalized Maxwell (Prony) series on fixed log-spaced relaxation times plus a static and
   (if the data need it) a constant-loss term, whose coefficients are Bernstein polynomials in
   ``ln X`` with non-negative coefficients. Every coefficient ``>= 0``: passive at every
   frequency and amplitude by construction.
3. The fit is a convex quadratic program (cvxpy, Clarabel): least squares of the residuals
   relative to the measured ``|k|`` (the rig's noise is relative to the total), subject to
   non-negativity and to **softening** (the storage stiffness's Bernstein coefficients
   non-increasing in the amplitude, on a frequency grid: storage non-increasing in X there),
   plus ``lambda`` times a roughness penalty (second differences of the relaxation spectrum
   along ``tau``, and of the model's stiffness across the amplitude coefficients: smoothness
   across amplitudes).
4. ``lambda`` is chosen by K-fold cross-validation over the measured points (the prediction
   error on held-out points) from a log grid; the constant-loss term is kept only if it lowers
   the cross-validated error by more than 2 %. Both choices are reported.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from isodesign.calibration.data import MeasuredStiffness
from isodesign.errors import InputError, SolverError
from isodesign.spring.diaphragm import FittedDiaphragm, bernstein_basis
from isodesign.spring.stiffness import complex_stiffness

__all__ = [
    "MIN_FREQUENCIES_PER_AMPLITUDE",
    "DiaphragmFit",
    "air_share",
    "fit_diaphragm",
]

#: Fewer distinct frequencies than this at one amplitude is too sparse to identify k_D*(w).
MIN_FREQUENCIES_PER_AMPLITUDE = 4
#: A point is "not passive" when the diaphragm's share has Im k_D* below this fraction of the
#: measured |k| (beyond plausible noise); more than a quarter of an amplitude's points so
#: flagged rejects the data.
NON_PASSIVE_TOLERANCE = 0.02
#: Relaxation times per decade, and the decades added beyond the measured frequency range.
TAU_PER_DECADE = 3
TAU_MARGIN_DECADES = 0.5
#: Highest degree of the Bernstein polynomials in ln X.
MAX_DEGREE = 4
#: Default grid of the regularization weight (relative to the misfit of relative residuals).
DEFAULT_LAMBDAS = tuple(10.0 ** np.arange(-5.0, 4.5, 1.0))
#: Keep the constant-loss term if it lowers the cross-validated error by more than this.
HYSTERETIC_GAIN = 0.02


@dataclass(frozen=True, eq=False)
class DiaphragmFit:
    """Result of :func:`fit_diaphragm`.

    Attributes
    ----------
    model : FittedDiaphragm
    measured : MeasuredStiffness
    k_air : ndarray of complex
        The air's share subtracted at each point (k_s or k_d*), N/m.
    k_diaphragm_measured, k_diaphragm_fit : ndarray of complex
        Measured minus air, and the fitted model, at each point, N/m.
    relative_residual : ndarray of complex
        ``(k_fit - k_measured) / |k_measured|`` of the total stiffness at each point.
    amplitude_levels_m : ndarray
    level_index : ndarray of int
    regularization : float
        The chosen ``lambda``.
    cv_table : list of (lambda, hysteretic, cv_rms)
    hysteretic : bool
        The constant-loss term was kept.
    flags : tuple of str
        Where the data are sparse, not passive, or the fit is poor.
    air_model : str
    """

    model: FittedDiaphragm
    measured: MeasuredStiffness
    k_air: np.ndarray
    k_diaphragm_measured: np.ndarray
    k_diaphragm_fit: np.ndarray
    relative_residual: np.ndarray
    amplitude_levels_m: np.ndarray
    level_index: np.ndarray
    regularization: float
    cv_table: tuple = ()
    hysteretic: bool = False
    flags: tuple[str, ...] = ()
    air_model: str = ""
    solve_time_s: float = field(default=0.0, repr=False)

    @property
    def rms_relative_residual(self) -> float:
        """RMS over points and real/imaginary parts of the relative residual."""
        r = self.relative_residual
        return float(np.sqrt(np.mean(np.r_[r.real, r.imag] ** 2)))

    @property
    def cv_rms(self) -> float:
        """Cross-validated RMS relative error of the chosen model."""
        best = [c for c in self.cv_table if c[0] == self.regularization and c[1] == self.hysteretic]
        return float(best[0][2]) if best else float("nan")

    def report(self) -> str:
        """Text report: data, choices, residuals per amplitude, flags."""
        m = self.measured
        n_lam = len({c[0] for c in self.cv_table})
        lines = [
            f"diaphragm fit: {m.source or 'data'} ({m.configuration}, {m.frequency_hz.size} "
            f"points, {self.amplitude_levels_m.size} amplitudes "
            f"{', '.join(f'{x * 1e3:.4g}' for x in self.amplitude_levels_m)} mm, "
            f"{m.frequency_hz.min():.3g}-{m.frequency_hz.max():.3g} Hz); air: {self.air_model}",
            f"model: Prony series, {self.model.relaxation_times_s.size} relaxation times "
            f"{self.model.relaxation_times_s.min():.3g}-{self.model.relaxation_times_s.max():.3g}"
            f" s, static term, constant-loss term {'kept' if self.hysteretic else 'not needed'};"
            f" Bernstein degree {self.model.degree} in ln X; passive by construction",
            f"regularization lambda = {self.regularization:.3g} by {n_lam}"
            f"-value cross-validation (CV RMS error {self.cv_rms:.2%} of |k|); fit RMS "
            f"residual {self.rms_relative_residual:.2%} of |k|",
            "  amplitude   points   RMS res. Re   RMS res. Im   Re k_D (fit, mid f)   eta_D",
        ]
        r = self.relative_residual
        for j, x in enumerate(self.amplitude_levels_m):
            sel = self.level_index == j
            fm = math.exp(np.mean(np.log(m.frequency_hz[sel])))
            kd = self.model.stiffness(2 * math.pi * fm, x)
            rre, rim = np.sqrt(np.mean(r.real[sel] ** 2)), np.sqrt(np.mean(r.imag[sel] ** 2))
            lines.append(
                f"  {x * 1e3:7.4g} mm  {int(sel.sum()):6d}   {rre:10.2%}"
                f"   {rim:10.2%}   {float(kd.re):12.5g} N/m"
                f"     {float(kd.im) / float(kd.re):.3f}"
            )
        lines += [f"note: {f}" for f in self.flags]
        return "\n".join(lines)

    def to_toml(self) -> str:
        """The fit file (``fit:PATH.toml``), with the report's numbers as ``[fit_report]``."""
        header = (
            "Diaphragm identified by 'isodesign fit diaphragm' (docs/calibration.md).\n"
            f"data: {self.measured.source} ({self.measured.configuration}); air: {self.air_model}"
        )
        extra = {
            "regularization": self.regularization,
            "cv_rms_relative": self.cv_rms,
            "rms_relative_residual": self.rms_relative_residual,
            "hysteretic_term": self.hysteretic,
            "points": int(self.measured.frequency_hz.size),
            "flags": "; ".join(self.flags),
        }
        return self.model.to_toml(header=header, extra=extra)

    def plot(self, path, *, dpi: int = 130) -> Path:
        """Measured against fitted: Re k_D and loss factor vs frequency per amplitude, and
        the residuals of the total stiffness."""
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        fig = Figure(figsize=(9.5, 8.5), layout="constrained")
        FigureCanvasAgg(fig)
        ax1, ax2, ax3 = fig.subplots(3, 1, sharex=True)
        m = self.measured
        fmin, fmax = m.frequency_hz.min(), m.frequency_hz.max()
        fg = np.geomspace(fmin, fmax, 200)
        for j, x in enumerate(self.amplitude_levels_m):
            c = f"C{j % 10}"
            sel = np.flatnonzero(self.level_index == j)
            sel = sel[np.argsort(m.frequency_hz[sel])]
            f = m.frequency_hz[sel]
            kd = self.k_diaphragm_measured[sel]
            kf = self.model.stiffness(2 * math.pi * fg, x)
            re_f, im_f = np.asarray(kf.re), np.asarray(kf.im)
            lab = f"X = {x * 1e3:.3g} mm"
            ax1.plot(f, kd.real / 1e3, "o", color=c, ms=4, label=f"{lab} measured - air")
            ax1.plot(fg, re_f / 1e3, "-", color=c, lw=1.2, label=f"{lab} fit")
            ax2.plot(f, kd.imag / kd.real, "o", color=c, ms=4)
            ax2.plot(fg, im_f / re_f, "-", color=c, lw=1.2)
            r = self.relative_residual[sel]
            ax3.plot(f, 100 * r.real, "o-", color=c, ms=3, lw=0.6)
            ax3.plot(f, 100 * r.imag, "s--", color=c, ms=3, lw=0.6, mfc="none")
        ax1.set_ylabel("Re k_D (kN/m)")
        ax1.set_title(
            f"diaphragm fit ({m.configuration}): lambda {self.regularization:.2g}, "
            f"RMS residual {self.rms_relative_residual:.2%} of |k|"
        )
        ax1.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
        ax2.set_ylabel("loss factor Im k_D / Re k_D")
        ax3.set_ylabel("residual of k (% of |k|)\no: Re, s: Im")
        ax3.axhline(0.0, color="0.5", lw=0.8)
        ax3.set_xlabel("frequency (Hz)")
        ax3.set_xscale("log")
        for ax in (ax1, ax2, ax3):
            ax.grid(True, which="both", alpha=0.3)
        p = Path(path)
        fig.savefig(p, dpi=dpi)
        return p


def air_share(
    measured: MeasuredStiffness,
    design,
    *,
    flow: str = "quasi_steady",
    amplitude_mode: str = "self_consistent",
) -> tuple[np.ndarray, str]:
    """The air's stiffness at the measured points and a label of the model used.

    ``single_chamber``: ``k_s`` (Eq. 40), real and constant. ``dual_chamber``: ``k_d*``
    (Eq. 38) from :func:`complex_stiffness` with ``diaphragm="none"``.

    Parameters
    ----------
    measured : MeasuredStiffness
        The points (and the configuration).
    design : SpringDesign
        The spring on the rig.
    flow, amplitude_mode : str
        Air model of dual-chamber data.

    Returns
    -------
    tuple of (ndarray of complex, str)
    """
    if measured.configuration == "single_chamber":
        ks = float(design.single_chamber_stiffness_n_per_m)
        return np.full(measured.k.shape, ks, dtype=complex), f"k_s (Eq. 40) = {ks:.6g} N/m"
    res = complex_stiffness(
        design,
        measured.frequency_hz,
        measured.amplitude_m,
        flow=flow,
        amplitude_mode=amplitude_mode,
        diaphragm="none",
        pairwise=True,
        warn=False,
    )
    return np.asarray(res.k), f"k_d* (Eq. 38; flow={flow}, amplitude_mode={amplitude_mode})"


def _check_data(measured, kd, levels, idx) -> list[str]:
    """Too-sparse and non-passive data raise; milder problems become flags."""
    flags: list[str] = []
    where = f" ({measured.source})" if measured.source else ""
    f = measured.frequency_hz
    for j, x in enumerate(levels):
        sel = idx == j
        fj = np.unique(np.round(f[sel], 9))
        if fj.size < MIN_FREQUENCIES_PER_AMPLITUDE:
            raise InputError(
                f"measured stiffness{where}: too sparse: amplitude {x * 1e3:.4g} mm has "
                f"{fj.size} distinct frequencies; at least {MIN_FREQUENCIES_PER_AMPLITUDE} are "
                "needed to identify k_D*(w) at an amplitude"
            )
        if fj.max() / fj.min() < 10.0:
            flags.append(
                f"amplitude {x * 1e3:.4g} mm spans only {fj.min():.3g}-{fj.max():.3g} Hz (less "
                "than a decade): the relaxation spectrum is poorly determined there"
            )
        gaps = np.flatnonzero(fj[1:] / fj[:-1] > 2.0)
        for g in gaps:
            flags.append(
                f"amplitude {x * 1e3:.4g} mm: sparse between {fj[g]:.3g} and {fj[g + 1]:.3g} Hz "
                "(no data for more than an octave)"
            )
        neg = sel & (kd.imag < -NON_PASSIVE_TOLERANCE * np.abs(measured.k))
        if neg.sum() > 0.25 * sel.sum():
            raise InputError(
                f"measured stiffness{where}: not passive: after subtracting the air, Im k_D* < 0 "
                f"(beyond {NON_PASSIVE_TOLERANCE:.0%} of |k|) at {int(neg.sum())} of "
                f"{int(sel.sum())} points at amplitude {x * 1e3:.4g} mm. Check the phase sign "
                "(the force must lead the displacement), the configuration and the design "
                "(the air model subtracted)"
            )
        for i in np.flatnonzero(neg):
            flags.append(
                f"not passive at {f[i]:.3g} Hz, {measured.amplitude_m[i] * 1e3:.4g} mm: "
                f"Im k_D* = {kd.imag[i]:.4g} N/m (the passive fit cannot follow it)"
            )
    med = [float(np.median(kd.real[idx == j])) for j in range(levels.size)]
    for j in range(levels.size - 1):
        if med[j + 1] > 1.02 * med[j]:
            flags.append(
                f"the data stiffen from {levels[j] * 1e3:.4g} to {levels[j + 1] * 1e3:.4g} mm "
                f"(median Re k_D* {med[j]:.4g} -> {med[j + 1]:.4g} N/m): the softening "
                "constraint does not let the fit follow (check the amplitudes and the air model)"
            )
    if np.any(kd.real <= 0):
        flags.append(
            f"Re k_D* <= 0 at {int(np.sum(kd.real <= 0))} points: the air model or the design "
            "may not match the rig"
        )
    return flags


class _Problem:
    """The convex QP with cvxpy parameters for the fold mask and lambda (compiled once)."""

    def __init__(self, a_rows, b_rows, rough, soft, n_per_m, hyst_cols, hysteretic):
        import cvxpy as cp

        self.x = cp.Variable(a_rows.shape[1], nonneg=True)
        self.mask = cp.Parameter(a_rows.shape[0], nonneg=True)
        self.lam = cp.Parameter(nonneg=True)
        resid = cp.multiply(self.mask, a_rows @ self.x - b_rows)
        obj = cp.sum_squares(resid) + self.lam * cp.sum_squares(rough @ self.x)
        cons = []
        if soft.shape[0]:
            cons.append(soft @ self.x <= 0)
        if not hysteretic:
            cons.append(self.x[hyst_cols] == 0)
        self.prob = cp.Problem(cp.Minimize(obj), cons)
        self.a, self.b = a_rows, b_rows

    def solve(self, mask, lam) -> np.ndarray:
        import cvxpy as cp

        self.mask.value = mask
        self.lam.value = lam
        try:
            self.prob.solve(solver=cp.CLARABEL)
        except cp.error.SolverError as exc:
            raise SolverError(f"diaphragm fit: the QP solver failed ({exc})") from None
        if self.prob.status not in ("optimal", "optimal_inaccurate") or self.x.value is None:
            raise SolverError(f"diaphragm fit: the QP ended with status {self.prob.status}")
        return np.maximum(np.asarray(self.x.value), 0.0)


def fit_diaphragm(
    measured: MeasuredStiffness,
    design,
    *,
    flow: str = "quasi_steady",
    amplitude_mode: str = "self_consistent",
    degree: int | None = None,
    lambdas=DEFAULT_LAMBDAS,
    hysteretic: str | bool = "auto",
    folds: int = 5,
    seed: int = 0,
) -> DiaphragmFit:
    """Identify the diaphragm's complex stiffness from measured spring stiffness.

    Parameters
    ----------
    measured : MeasuredStiffness
        Total stiffness (air + diaphragm), single- or dual-chamber.
    design : SpringDesign
        The spring on the rig (for the air's share: k_s or k_d*).
    flow, amplitude_mode : str
        Air model of dual-chamber data (:func:`complex_stiffness`).
    degree : int, optional
        Degree of the Bernstein polynomials in ln X (default: number of amplitudes - 1, at
        most 4).
    lambdas : sequence of float
        Candidate regularization weights (cross-validated).
    hysteretic : {'auto', True, False}
        Constant-loss term: chosen by cross-validation, always, never.
    folds : int
        Cross-validation folds (points assigned at random with ``seed``).
    seed : int
        Seed of the random fold assignment.

    Returns
    -------
    DiaphragmFit

    Raises
    ------
    InputError
        Too sparse (fewer than 4 frequencies at an amplitude, fewer points than folds) or not
        passive (see :data:`NON_PASSIVE_TOLERANCE`).
    """
    import time

    t0 = time.perf_counter()
    k_air, air_label = air_share(measured, design, flow=flow, amplitude_mode=amplitude_mode)
    kd = measured.k - k_air
    levels, idx = measured.amplitude_levels()
    flags = _check_data(measured, kd, levels, idx)
    n = measured.k.size
    if n < 2 * folds:
        raise InputError(
            f"measured stiffness: too sparse: {n} points for {folds}-fold cross-validation "
            f"(at least {2 * folds})"
        )
    if hysteretic not in ("auto", True, False):
        raise InputError(f"hysteretic: expected 'auto', true or false, got {hysteretic!r}")
    lambdas = tuple(float(v) for v in lambdas)
    if not lambdas or any(not (v >= 0 and math.isfinite(v)) for v in lambdas):
        raise InputError("lambdas: need at least one finite value >= 0")

    f = measured.frequency_hz
    w = 2 * math.pi * f
    fmin, fmax = float(f.min()), float(f.max())
    lo_dec = math.log10(fmin) - TAU_MARGIN_DECADES
    hi_dec = math.log10(fmax) + TAU_MARGIN_DECADES
    n_tau = max(3, round((hi_dec - lo_dec) * TAU_PER_DECADE) + 1)
    f_relax = 10.0 ** np.linspace(lo_dec, hi_dec, n_tau)
    tau = 1.0 / (2 * math.pi * f_relax)
    m_deg = min(levels.size - 1, MAX_DEGREE) if degree is None else int(degree)
    if not 0 <= m_deg <= 8:
        raise InputError(f"degree: must be in [0, 8], got {degree}")
    if m_deg > levels.size - 1:
        raise InputError(
            f"degree: {m_deg} needs at least {m_deg + 1} amplitudes, the data have {levels.size}"
        )
    x_lo, x_hi = float(levels.min()), float(levels.max())

    scale = float(np.median(np.abs(measured.k)))
    nb = n_tau + 2  # per Bernstein coefficient: static, n_tau weights, hysteretic
    npar = (m_deg + 1) * nb

    def t_of(x):
        if m_deg == 0:
            return np.zeros_like(x)
        return np.clip((np.log(x) - math.log(x_lo)) / (math.log(x_hi) - math.log(x_lo)), 0, 1)

    def relax(wv):
        wt = np.outer(wv, tau)
        return wt * wt / (1 + wt * wt), wt / (1 + wt * wt)

    # design matrices of the model (in units of `scale`) at the data points
    bern = np.array(bernstein_basis(t_of(measured.amplitude_m), m_deg)).T.reshape(n, m_deg + 1)
    rr, ri = relax(w)
    a_re = np.zeros((n, npar))
    a_im = np.zeros((n, npar))
    for m in range(m_deg + 1):
        o = m * nb
        a_re[:, o] = bern[:, m]
        a_re[:, o + 1 : o + 1 + n_tau] = bern[:, m : m + 1] * rr
        a_im[:, o + 1 : o + 1 + n_tau] = bern[:, m : m + 1] * ri
        a_im[:, o + nb - 1] = bern[:, m]
    wt_pt = scale / np.abs(measured.k)  # residuals relative to |k|
    a_rows = np.vstack([a_re * wt_pt[:, None], a_im * wt_pt[:, None]])
    b_rows = np.r_[kd.real / scale * wt_pt, kd.imag / scale * wt_pt]
    hyst_cols = [m * nb + nb - 1 for m in range(m_deg + 1)]

    # roughness: second differences along tau; across the amplitude coefficients on a grid
    rough = []
    for m in range(m_deg + 1):
        for i in range(n_tau - 2):
            r = np.zeros(npar)
            r[m * nb + 1 + i : m * nb + 4 + i] = (1.0, -2.0, 1.0)
            rough.append(r)
    w_grid = 2 * math.pi * np.geomspace(fmin, fmax, 12)
    gr, gi = relax(w_grid)

    def curve_rows(m):  # rows giving the m-th coefficient's Re and Im stiffness on the grid
        re = np.zeros((w_grid.size, npar))
        im = np.zeros((w_grid.size, npar))
        o = m * nb
        re[:, o] = 1.0
        re[:, o + 1 : o + 1 + n_tau] = gr
        im[:, o + 1 : o + 1 + n_tau] = gi
        im[:, o + nb - 1] = 1.0
        return re, im

    curves = [curve_rows(m) for m in range(m_deg + 1)]
    for m in range(m_deg - 1):
        for part in (0, 1):
            rough.extend(curves[m][part] - 2 * curves[m + 1][part] + curves[m + 2][part])
    rough_m = np.array(rough) if rough else np.zeros((1, npar))
    # softening: storage coefficient curves non-increasing in m, on a denser grid
    w_soft = 2 * math.pi * np.geomspace(fmin, fmax, 30)
    sr, _ = relax(w_soft)
    soft = []
    for m in range(m_deg):
        for k in range(w_soft.size):
            row = np.zeros(npar)
            row[(m + 1) * nb] += 1.0
            row[(m + 1) * nb + 1 : (m + 1) * nb + 1 + n_tau] += sr[k]
            row[m * nb] -= 1.0
            row[m * nb + 1 : m * nb + 1 + n_tau] -= sr[k]
            soft.append(row)
    soft_m = np.array(soft) if soft else np.zeros((0, npar))

    # cross-validation
    rng = np.random.default_rng(seed)
    fold_of = rng.permutation(np.arange(n) % folds)
    options = [True, False] if hysteretic == "auto" else [bool(hysteretic)]
    cv_table = []
    best = None
    problems = {}
    for hyst in options:
        prob = _Problem(a_rows, b_rows, rough_m, soft_m, n, hyst_cols, hyst)
        problems[hyst] = prob
        for lam in lambdas:
            err2 = 0.0
            for k in range(folds):
                test = fold_of == k
                mask = np.r_[~test, ~test].astype(float)
                x = prob.solve(mask, lam)
                res = (a_rows @ x - b_rows)[np.r_[test, test]]
                err2 += float(np.sum(res**2))
            cv = math.sqrt(err2 / (2 * n))
            cv_table.append((lam, hyst, cv))
    best_by = {}
    for lam, hyst, cv in cv_table:
        if hyst not in best_by or cv < best_by[hyst][1]:
            best_by[hyst] = (lam, cv)
    if True in best_by and False in best_by:
        use_h = best_by[True][1] < (1 - HYSTERETIC_GAIN) * best_by[False][1]
    else:
        use_h = options[0]
    lam_best = best_by[use_h][0]
    best = problems[use_h].solve(np.ones(2 * n), lam_best)

    p = best.reshape(m_deg + 1, nb) * scale
    model = FittedDiaphragm(
        relaxation_times_s=tau,
        static_n_per_m=p[:, 0],
        weights_n_per_m=p[:, 1 : 1 + n_tau],
        hysteretic_n_per_m=p[:, nb - 1] if use_h else np.zeros(m_deg + 1),
        amplitude_range_m=(x_lo, x_hi),
        frequency_range_hz=(fmin, fmax),
        source=str(measured.source),
    )
    kf = model.stiffness(w, measured.amplitude_m)
    k_fit = np.asarray(kf.re) + 1j * np.asarray(kf.im)
    rel = (k_fit + k_air - measured.k) / np.abs(measured.k)
    cv_h = sorted((lam, cv) for lam, h, cv in cv_table if h == use_h)
    for end, nxt in ((cv_h[0], cv_h[1:2]), (cv_h[-1], cv_h[-2:-1])):
        if nxt and end[0] == lam_best and end[1] < 0.99 * nxt[0][1]:
            flags.append(
                f"the chosen lambda {lam_best:.3g} is at the end of the candidate grid and the "
                "cross-validated error still falls there; widen the grid"
            )
    ratios = levels[1:] / levels[:-1]
    for j in np.flatnonzero(ratios > 2.05):
        flags.append(
            f"amplitudes {levels[j] * 1e3:.4g} to {levels[j + 1] * 1e3:.4g} mm: no data in "
            f"between (ratio {ratios[j]:.2g}); the model interpolates in ln X there"
        )
    noise = np.sqrt(np.mean(np.r_[rel.real, rel.imag] ** 2))
    for j, x in enumerate(levels):
        sel = idx == j
        rj = np.sqrt(np.mean(np.r_[rel.real[sel], rel.imag[sel]] ** 2))
        if rj > 2.5 * noise and rj > 0.01:
            flags.append(
                f"amplitude {x * 1e3:.4g} mm fits worse ({rj:.2%} RMS) than the rest "
                f"({noise:.2%}): data not consistent with a passive softening diaphragm?"
            )
    return DiaphragmFit(
        model=model,
        measured=measured,
        k_air=k_air,
        k_diaphragm_measured=kd,
        k_diaphragm_fit=k_fit,
        relative_residual=rel,
        amplitude_levels_m=levels,
        level_index=idx,
        regularization=lam_best,
        cv_table=tuple(cv_table),
        hysteretic=use_h,
        flags=tuple(flags),
        air_model=air_label,
        solve_time_s=time.perf_counter() - t0,
    )
