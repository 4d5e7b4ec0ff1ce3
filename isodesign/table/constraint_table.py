"""The constraint table of a table optimum: the NLP's rows and the exact checks.

The constraints whose NLP rows are the log of a quantity (the total volume, the vertical
natural frequency, ``ln |T|^2`` of the peak at the grid's and the refinement's frequencies)
are reported from those rows by :func:`isodesign.optimization.constraints.constraint_reports`,
under the names the vertical optimizer uses (so :mod:`isodesign.optimization.explain` words
them the same way). The constraints the NLP writes in a smooth surrogate form (the rocking
matrix, the frozen modes' Rayleigh quotients) are reported from the exact quantities at the
optimum: the rocking margin with gravity (:func:`isodesign.table.modes.rocking_stability`),
the damping ratio and frequency of the exact modes, and the continuous peak of |T| from
below the lowest mode (:mod:`isodesign.table.peaks`). Binding: within
:data:`~isodesign.optimization.constraints.BINDING_TOL` of the bound in the log of the
quantity (0.5 %), or in ``ln |T|^2`` (0.022 dB).
"""

from __future__ import annotations

import math

import numpy as np

from isodesign.optimization.constraints import (
    BINDING_TOL,
    Constraint,
    ConstraintReport,
    constraint_reports,
)

__all__ = ["CONTINUOUS_PEAK", "NLP_ROW_NAMES", "table_constraint_reports"]

#: Name of the continuous peak's row (and of its violation).
CONTINUOUS_PEAK = "continuous_peak_transmissibility"
#: The table NLP's constraint groups reported from their rows: NLP name -> (report name,
#: description).
NLP_ROW_NAMES = {
    "max_total_volume_m3": ("total_volume", "V_t0 (1 + N) of one isolator"),
    "natural_frequency_hz": ("natural_frequency",
                             "vertical mode sqrt(sum K0_i / m) of the leveled table"),
    "max_peak_transmissibility_db": ("peak_transmissibility",
                                     "|T_p,aa| at the NLP's grid and refinement frequencies"),
}
_LN10 = math.log(10.0)


def _report(name, value, lower, upper, unit, margin, description) -> ConstraintReport:
    return ConstraintReport(name=name, value=float(value), lower=lower, upper=upper, unit=unit,
                            margin=float(margin), active=bool(margin < BINDING_TOL),
                            description=description)


def _log_margin(value, lower=None, upper=None) -> float:
    m = math.inf
    if lower:
        m = min(m, math.log(value / lower) if value > 0 else -math.inf)
    if upper:
        m = min(m, math.log(upper / value) if value > 0 else math.inf)
    return m


def table_constraint_reports(prob, g, *, modes=None, stability=None,
                             peaks=None) -> list[ConstraintReport]:
    """The constraints of a table design, in natural units, with margins and binding flags.

    Parameters
    ----------
    prob : TableProblem
        Its ``con_rows``, ``lbg``, ``ubg`` and study (the bounds).
    g : ndarray
        The NLP's constraint values at the design (``Solution.g``).
    modes : TableModes, optional
        The design's exact modes (damping, rocking frequencies).
    stability : RockingStability, optional
        The design's rocking margins with gravity.
    peaks : TablePeaks, optional
        The design's continuous peak of |T|.

    Returns
    -------
    list of ConstraintReport
    """
    c = prob.study.constraints
    rows = []
    for name, row, m in prob.con_rows:
        if name not in NLP_ROW_NAMES:
            continue
        rep, desc = NLP_ROW_NAMES[name]
        rows.append((Constraint(rep, None, float(prob.lbg[row]), float(prob.ubg[row]), m,
                                desc), row, m))
    out = constraint_reports(rows, np.asarray(g, float))
    pk = c.get("max_peak_transmissibility_db")
    if peaks is not None and pk is not None and pk is not False:
        p, a, v, f = peaks.worst()
        out.append(_report(CONTINUOUS_PEAK, v, None, float(pk), "dB", (pk - v) * _LN10 / 10.0,
                           f"|T| between the grid's frequencies, {peaks.f_low_hz:.3g}-"
                           f"{peaks.f_high_hz:.3g} Hz (worst {p} {a} at {f:.3g} Hz)"))
    smax = c.get("max_stroke_m")
    for name, row, m in prob.con_rows if smax else ():
        if name == "max_stroke_m":  # ln(peak factor x sigma_i) <= ln max_stroke_m
            gi = np.asarray(g, float)[row: row + m]
            v = float(np.exp(np.max(gi)))
            out.append(_report("stroke", v, None, float(smax), "m", math.log(smax / v),
                               f"{c.get('stroke_peak_factor'):g} x RMS vertical stroke, "
                               "worst isolator, against its travel"))
    mu = c.get("min_tilt_margin")
    if stability is not None and mu:
        v = float(np.min(stability.margin))
        out.append(_report("tilt_margin", v, float(mu), None, "-", _log_margin(v, lower=mu),
                           "rocking K_theta / (W h), weakest direction, with gravity"))
    if modes is not None:
        f = np.asarray(modes.frequency_hz, float)
        zmin = c.get("min_damping_ratio")
        low = np.isfinite(f) & (f < 5.0)
        if zmin and np.any(low):
            v = float(np.min(modes.damping_ratio[low]))
            out.append(_report("damping_ratio", v, float(zmin), None, "-",
                               _log_margin(v, lower=zmin),
                               "least-damped exact mode below 5 Hz"))
        f_lo, f_hi = c.get("min_rocking_frequency_hz"), c.get("max_rocking_frequency_hz")
        rock = np.isfinite(f) & (modes.energy_fraction[:, 3:5].sum(axis=1) >= 0.3)
        if (f_lo or f_hi) and np.any(rock):
            fr = f[rock]
            v = float(fr.min()) if f_lo else float(fr.max())
            m = min(_log_margin(float(fr.min()), lower=f_lo or None),
                    _log_margin(float(fr.max()), upper=f_hi or None))
            out.append(_report("rocking_frequency", v, float(f_lo) if f_lo else None,
                               float(f_hi) if f_hi else None, "Hz", m,
                               "exact rocking modes (rx + ry energy >= 30 %)"))
    return out
