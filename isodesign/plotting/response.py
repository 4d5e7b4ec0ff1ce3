"""Figures of the payload response: band RMS velocity against the target, transmissibility.

Functions draw into given axes (``draw_*``) or build a whole figure (``*_figure``) and
return the :class:`~matplotlib.figure.Figure`; none writes a file (see
:func:`isodesign.plotting.style.save_figure`).
"""

from __future__ import annotations

import numpy as np

from isodesign.plotting.style import (
    FAIL,
    FLAGGED_SPAN,
    FLOOR,
    LIMIT,
    LINEAR,
    OPTIMUM,
    PEAK_LIMIT,
    UNITY,
    band_axis,
    candidate_style,
    frequency_axis,
    new_figure,
)

__all__ = [
    "UM_PER_UIN",
    "band_response_figure",
    "bands_figure",
    "design_caption",
    "draw_bands",
    "draw_transmissibility",
    "finish_transmissibility",
    "floor_label",
    "harmonic_figure",
    "judged_mask",
    "transmissibility_figure",
]

#: Micrometres per microinch (criteria are quoted in both).
UM_PER_UIN = 0.0254


def design_caption(design) -> str:
    """``N 4.1, V_t0 1.18 L, L_c 180 mm, D_c 2.14 mm`` (per isolator).

    Parameters
    ----------
    design : SpringDesign
    """
    return (f"N {design.volume_ratio:.3g}, V_t0 {design.top_volume_m3 * 1e3:.3g} L, "
            f"L_c {design.capillary_length_m * 1e3:.3g} mm, "
            f"D_c {design.capillary_diameter_m * 1e3:.3g} mm")


def floor_label(name: str) -> str:
    """``VC-A floor`` as it is, ``site.csv`` as ``floor: site.csv``.

    Parameters
    ----------
    name : str
        The floor spectrum's name.
    """
    name = name or "floor"
    return name if "floor" in name.lower() else f"floor: {name}"


def judged_mask(bands, judged_hz=None) -> np.ndarray:
    """Bands whose nominal centre lies in ``judged_hz = (lo, hi)`` (all when None).

    Parameters
    ----------
    bands : Bands
    judged_hz : (float, float), optional
        Nominal band centres, Hz, both included.

    Returns
    -------
    ndarray of bool
    """
    nominal = np.asarray(bands.nominal_hz, float)
    if judged_hz is None:
        return np.ones(nominal.shape, bool)
    lo, hi = judged_hz
    return (nominal >= lo * (1 - 1e-9)) & (nominal <= hi * (1 + 1e-9))


def _verdict_word(res, judged) -> tuple[str, float, str]:
    m = np.asarray(res.margin_db, float)
    mj = np.where(judged, m, np.inf)
    i = int(np.argmin(mj))
    ok = bool(np.all(m[judged] >= 0.0))
    return ("PASS" if ok else "FAIL"), float(m[i]), res.bands.labels[i]


def draw_bands(ax, entries, *, judged=None, floor=True, limit=True, legend=True) -> None:
    """Band RMS velocity of the floor, of each payload response and the target (um/s).

    Parameters
    ----------
    ax : matplotlib Axes
    entries : sequence of (label, BandResponse, style dict)
        Payload responses on the same bands; the first one provides the floor and the
        target curve.
    judged : ndarray of bool, optional
        Judged bands (shaded; failing judged bands are circled). Default: all.
    floor, limit, legend : bool
        Draw the floor, the limit, the legend.
    """
    res0 = entries[0][1]
    c = np.asarray(res0.bands.centre_hz, float)
    judged = np.ones(c.shape, bool) if judged is None else np.asarray(judged, bool)
    um = 1e6
    band_axis(ax, res0.bands, judged=judged)
    if floor:
        ax.plot(c, res0.floor_velocity_rms_m_s * um, **FLOOR,
                label=floor_label(res0.floor_name))
    if limit:
        ax.plot(c, res0.limit_velocity_rms_m_s * um, **LIMIT,
                label=f"limit: {res0.target_name}")
    failed = False
    for label, res, style in entries:
        v = np.asarray(res.payload_velocity_rms_m_s, float) * um
        ax.plot(c, v, **style, label=label)
        bad = judged & ~np.asarray(res.band_passes, bool)
        if bad.any():
            ax.plot(c[bad], v[bad], **FAIL,
                    label=None if failed else "judged band over the limit")
            failed = True
    ax.set_yscale("log")
    ax.set_ylabel("band RMS velocity (um/s)")
    sec = ax.secondary_yaxis("right", functions=(lambda v: v / UM_PER_UIN,
                                                 lambda v: v * UM_PER_UIN))
    sec.set_ylabel("band RMS velocity (uin/s)")
    ax.grid(True, which="major", lw=0.4, alpha=0.6)
    ax.grid(True, which="minor", axis="x", lw=0.3, alpha=0.35)
    if legend:
        ax.legend(fontsize=7.5, loc="best", framealpha=0.9)


def _db(t):
    with np.errstate(divide="ignore"):
        return 20.0 * np.log10(np.abs(t))


def _phase_deg(t) -> np.ndarray:
    """Unwrapped phase in degrees, with NaN where it still jumps by more than 180 degrees."""
    t = np.asarray(t)
    ph = np.degrees(np.unwrap(np.angle(t)))
    jump = np.abs(np.diff(ph)) > 180.0
    if jump.any():
        ph = ph.copy()
        ph[1:][jump] = np.nan
    return ph


def draw_transmissibility(ax_mag, ax_phase, frequency_hz, transmissibility, *, style, label,
                          valid=None, flagged_label=True) -> bool:
    """|T| in dB (and its phase) against frequency; points outside validity crossed.

    Returns True when flagged points were drawn.

    Parameters
    ----------
    ax_mag, ax_phase : matplotlib Axes
        |T| (dB) and phase axes (``ax_phase`` None: magnitude only).
    frequency_hz : array_like
    transmissibility : array_like of complex
    style : dict
        Line style (:mod:`isodesign.plotting.style`).
    label : str
    valid : array_like of bool, optional
        False where a model is outside its validity.
    flagged_label : bool
        Put the flag entry in the legend.

    Returns
    -------
    bool
    """
    f = np.asarray(frequency_hz, float)
    t = np.asarray(transmissibility)
    st = {k: v for k, v in style.items() if k not in ("marker", "ms")}
    ax_mag.plot(f, _db(t), **st, label=label)
    if ax_phase is not None:
        ax_phase.plot(f, _phase_deg(t), **st)
    if valid is None:
        return False
    bad = ~np.asarray(valid, bool).reshape(f.shape)
    if not bad.any():
        return False
    # a band under the curve where the model is outside its validity (NaN elsewhere)
    ax_mag.plot(f, np.where(bad, _db(t), np.nan), **FLAGGED_SPAN,
                label="outside model validity" if flagged_label else None)
    return True


def finish_transmissibility(ax_mag, ax_phase, f, peak_limit_db, legend=True) -> None:
    """The 0 dB line, the peak limit, axis labels, frequency ticks and the legend.

    Parameters
    ----------
    ax_mag, ax_phase : matplotlib Axes
    f : array_like
        Frequencies drawn, Hz (the axis range).
    peak_limit_db : float or None
    legend : bool
    """
    ax_mag.axhline(0.0, **UNITY, label="|T| = 1 (0 dB)")
    if peak_limit_db is not None:
        ax_mag.axhline(peak_limit_db, **PEAK_LIMIT, label=f"peak limit {peak_limit_db:g} dB")
    ax_mag.set_ylabel("|T| payload/floor (dB)")
    ax_mag.grid(True, which="major", lw=0.4, alpha=0.6)
    lo, hi = float(np.min(f)), float(np.max(f))
    frequency_axis(ax_mag, lo, hi, label=ax_phase is None)
    if ax_phase is not None:
        frequency_axis(ax_phase, lo, hi)
        ax_phase.set_ylabel("phase of T (deg)")
        ax_phase.grid(True, which="major", lw=0.4, alpha=0.6)
        from matplotlib.ticker import MultipleLocator

        ax_phase.yaxis.set_major_locator(MultipleLocator(45))
    if legend:
        ax_mag.legend(fontsize=7.5, loc="best", framealpha=0.9)


def band_response_figure(res, *, judged=None, title=None, peak_limit_db=None, fig=None):
    """Overview of a :class:`~isodesign.response.random_input.BandResponse`.

    Left: floor, payload and limit per band (um/s and uin/s), the judged range shaded,
    failing judged bands circled. Right: |T| in dB and its phase at the operating
    amplitude A* and in the linear regime, the 0 dB line, the peak limit, points
    outside the spring model's validity crossed.

    Parameters
    ----------
    res : BandResponse
    judged : ndarray of bool or (lo, hi), optional
        Judged bands (mask over ``res.bands`` or nominal range in Hz); default all.
    title : str, optional
        Default: the design, payload, floor and verdict.
    peak_limit_db : float, optional
        A peak-|T| limit to draw.
    fig : Figure, optional
        Drawn into (cleared first); default a new one.

    Returns
    -------
    Figure
    """
    if judged is None or (isinstance(judged, tuple) and len(judged) == 2):
        judged = judged_mask(res.bands, judged)
    if fig is None:
        fig = new_figure(12.0, 5.2)
    else:
        fig.clear()
    gs = fig.add_gridspec(2, 2, width_ratios=(1.15, 1.0), height_ratios=(1.6, 1.0))
    ax_b = fig.add_subplot(gs[:, 0])
    ax_m = fig.add_subplot(gs[0, 1])
    ax_p = fig.add_subplot(gs[1, 1], sharex=ax_m)
    word, worst, band = _verdict_word(res, judged)
    draw_bands(ax_b, [("payload", res, OPTIMUM)], judged=judged)
    ax_b.set_title(f"{word}: worst judged band {band} Hz, margin {worst:+.2f} dB",
                   fontsize=10, color="C2" if word == "PASS" else "C3", fontweight="bold")
    f = res.grid.frequency_hz
    draw_transmissibility(ax_m, ax_p, f, res.transmissibility, style=OPTIMUM,
                          label=f"at the operating amplitude "
                                f"(stroke {res.equivalent_amplitude_m * 1e6:.3g} um)",
                          valid=np.asarray(res.spring_diagnostics.valid).reshape(-1)
                          if np.asarray(res.spring_diagnostics.valid).size == f.size else None)
    draw_transmissibility(ax_m, ax_p, f, res.transmissibility_linear, style=LINEAR,
                          label="linear regime (1 um stroke)")
    finish_transmissibility(ax_m, ax_p, f, peak_limit_db)
    ax_m.set_title("transmissibility floor -> payload", fontsize=10)
    if title is None:
        p = res.payload
        title = (f"{design_caption(res.design)} per isolator; payload {p.mass_kg:g} kg on "
                 f"{p.isolators} isolators; {floor_label(res.floor_name)}; limit "
                 f"{res.target_name}")
    fig.suptitle(title, fontsize=10)
    return fig


def bands_figure(entries, *, judged=None, title=None, ax=None):
    """Band RMS velocity of several payload responses (a comparison) on one axes.

    Parameters
    ----------
    entries : sequence of (label, BandResponse, style dict)
        The first provides the floor and the limit.
    judged : array_like of bool, optional
    title : str, optional
    ax : matplotlib Axes, optional

    Returns
    -------
    Figure
    """
    if ax is None:
        fig = new_figure(8.5, 5.0)
        ax = fig.add_subplot()
    else:
        fig = ax.figure
    draw_bands(ax, entries, judged=judged)
    if title:
        ax.set_title(title, fontsize=10)
    return fig


def transmissibility_figure(curves, *, peak_limit_db=None, title=None, fig=None):
    """|T| (dB) and phase of several curves: ``(label, frequency_hz, T, style, valid)``.

    Parameters
    ----------
    curves : sequence of (label, frequency_hz, T, style, valid or None)
    peak_limit_db : float, optional
    title : str, optional
    fig : Figure, optional

    Returns
    -------
    Figure
    """
    if fig is None:
        fig = new_figure(8.5, 5.6)
    ax_m, ax_p = fig.subplots(2, 1, sharex=True, height_ratios=(1.6, 1.0))
    flagged = False
    f_all = []
    for label, f, t, style, valid in curves:
        flagged |= draw_transmissibility(ax_m, ax_p, f, t, style=style, label=label,
                                         valid=valid, flagged_label=not flagged)
        f_all.append(np.asarray(f, float))
    f_all = np.concatenate(f_all)
    finish_transmissibility(ax_m, ax_p, f_all, peak_limit_db)
    if title:
        ax_m.set_title(title, fontsize=10)
    return fig


def harmonic_figure(res, *, title=None, peak_limit_db=None, fig=None):
    """A :class:`~isodesign.response.harmonic.HarmonicResponse`: |T| (dB), phase, stroke.

    One curve per floor amplitude, the linear regime drawn thin and dashed on top (it
    coincides with the smallest amplitudes), the 0 dB line, the peak limit, points with
    several self-consistent strokes (jump phenomenon) and points outside the spring
    model's validity marked.

    Parameters
    ----------
    res : HarmonicResponse
    title : str, optional
        Default: the design, payload and models.
    peak_limit_db : float, optional
    fig : Figure, optional

    Returns
    -------
    Figure
    """
    if fig is None:
        fig = new_figure(12.0, 5.6)
    else:
        fig.clear()
    gs = fig.add_gridspec(2, 2, height_ratios=(1.6, 1.0))
    ax_m = fig.add_subplot(gs[0, 0])
    ax_p = fig.add_subplot(gs[1, 0], sharex=ax_m)
    ax_s = fig.add_subplot(gs[:, 1])
    f = np.asarray(res.frequency_hz, float)
    valid = np.asarray(res.spring.valid, bool).reshape(res.stroke_m.shape)
    flagged = False
    multi_drawn = False
    for j, xf in enumerate(res.floor_amplitude_m):
        st = candidate_style(j)
        st = {k: v for k, v in st.items() if k not in ("marker", "ms")}
        lab = f"floor amplitude {xf * 1e6:.3g} um"
        flagged |= draw_transmissibility(ax_m, ax_p, f, res.transmissibility[:, j], style=st,
                                         label=lab, valid=valid[:, j],
                                         flagged_label=not flagged)
        ax_s.plot(f, res.stroke_m[:, j] * 1e6, **st, label=lab)
        multi = np.asarray(res.multiple_roots[:, j], bool)
        if multi.any():
            ax_m.plot(f[multi], _db(res.transmissibility[multi, j]), ls="none", marker="o",
                      mfc="none", mec="k", ms=5,
                      label=None if multi_drawn else "several strokes (jump)")
            multi_drawn = True
    draw_transmissibility(ax_m, ax_p, f, res.transmissibility_linear, style=LINEAR,
                          label="linear regime (1 um stroke)")
    finish_transmissibility(ax_m, ax_p, f, peak_limit_db)
    ax_m.set_title(f"transmissibility, {res.branch} branch where several strokes exist",
                   fontsize=10)
    frequency_axis(ax_s, float(f.min()), float(f.max()))
    ax_s.set_yscale("log")
    ax_s.set_ylabel("spring stroke amplitude per isolator (um)")
    ax_s.grid(True, which="major", lw=0.4, alpha=0.6)
    ax_s.legend(fontsize=7.5)
    ax_s.set_title("stroke X_s = |T - 1| X_f", fontsize=10)
    if title is None:
        p = res.payload
        s = res.stability
        title = (f"{design_caption(res.design)} per isolator; payload {p.mass_kg:g} kg on "
                 f"{p.isolators} isolators; harmonic floor motion ({s.flow} flow, "
                 f"{s.diaphragm} diaphragm)")
    fig.suptitle(title, fontsize=10)
    return fig
