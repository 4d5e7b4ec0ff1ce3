"""Figures of an optimization run: start design against optimum; the Pareto front."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from isodesign.optimization.analyze import vertical_band_response
from isodesign.optimization.objectives import OBJECTIVES
from isodesign.plotting.response import (
    design_caption,
    draw_bands,
    draw_transmissibility,
    finish_transmissibility,
    floor_label,
    judged_mask,
)
from isodesign.plotting.style import (
    LIMIT,
    OPTIMUM,
    START,
    new_figure,
    save_figure,
    with_breaks,
)

__all__ = [
    "all_bands_response",
    "case_margin_bars",
    "objective_display",
    "optimization_figure",
    "optimization_plot",
    "pareto_figure",
    "pareto_plot",
]

def objective_display(kind: str) -> tuple[float, str, str, bool]:
    """Display scale, unit, plain name and sense of an objective (its registry entry).

    Parameters
    ----------
    kind : str
        An objective name (:data:`isodesign.optimization.objectives.OBJECTIVES`).

    Returns
    -------
    (float, str, str, bool)
        Natural value x scale = displayed value; unit; label; True when maximized.
    """
    o = OBJECTIVES.get(kind)
    if o is None:
        return 1.0, "", kind, False
    return o.display_scale, o.display_unit, o.label, o.maximized


def all_bands_response(study, design):
    """Band response of ``design`` over every band of the floor and the target.

    The judged bands of a study (``target.band_min_hz``-``band_max_hz``) are a subset;
    the spring's operating amplitude does not depend on the bands (the stroke integral
    runs over the floor's whole range), so the judged bands' values are the same.
    Models as the optimizer's re-analysis.

    Parameters
    ----------
    study : Study
    design : SpringDesign
        With p0 from the payload.

    Returns
    -------
    BandResponse
    """
    return vertical_band_response(design, study.payload, study.floor, study.target, bands=None,
                                  flow=study.models["flow"],
                                  amplitude_mode=study.models["amplitude_mode"],
                                  diaphragm=study.models["diaphragm"], derive_pressure=False,
                                  warn=False)


#: Size of :func:`optimization_figure`'s own figure, inches.
FIGURE_SIZE_IN = (12.5, 5.4)
#: Its fixed layout: margins and gaps between the axes, inches. The room the constrained
#: layout gives the default study's figure, with spare width for the widest tick labels a
#: study gives (10^-3 um/s, -100 dB, -180 deg). Drawing with a constrained layout measured
#: every tick label in two extra passes: a third of the figure's time in ``optimize``.
FIXED_MARGINS_IN = {"left": 0.68, "right": 0.06, "bottom": 0.48, "top": 0.47,
                    "between_columns": 1.36, "between_rows": 0.34}


def _fixed_layout(size_in) -> dict:
    """:data:`FIXED_MARGINS_IN` as GridSpec parameters (fractions) of a 2 x 2 grid."""
    w, h = size_in
    m = FIXED_MARGINS_IN
    left, right = m["left"] / w, 1.0 - m["right"] / w
    bottom, top = m["bottom"] / h, 1.0 - m["top"] / h
    # GridSpec's spaces are fractions of the mean axes width (height)
    col = (right - left - m["between_columns"] / w) / 2.0
    row = (top - bottom - m["between_rows"] / h) / 2.0
    return {"left": left, "right": right, "bottom": bottom, "top": top,
            "wspace": m["between_columns"] / w / col, "hspace": m["between_rows"] / h / row}


def _judged_range(study):
    tg = study.raw["target"]
    return float(tg["band_min_hz"]), float(tg["band_max_hz"])


def optimization_figure(result, *, start_all=None, optimum_all=None, fig=None):
    """Start design against optimum: bands (all, the judged ones shaded) and |T| (dB, phase).

    Parameters
    ----------
    result : OptimizationResult
        A feasible result.
    start_all, optimum_all : BandResponse, optional
        Responses over all bands (default: computed with :func:`all_bands_response`).
    fig : Figure, optional

    Returns
    -------
    Figure
    """
    if result.analysis is None or result.start_analysis is None:
        raise ValueError("optimization_figure: the result has no band analysis (infeasible run)")
    st = result.study
    start_all = start_all or all_bands_response(st, st.design_at(result.start_values))
    optimum_all = optimum_all or all_bands_response(st, result.design)
    judged = judged_mask(optimum_all.bands, _judged_range(st))
    if fig is None:
        fig = new_figure(*FIGURE_SIZE_IN, layout=None)
        gs = fig.add_gridspec(2, 2, width_ratios=(1.15, 1.0), height_ratios=(1.6, 1.0),
                              **_fixed_layout(FIGURE_SIZE_IN))
    else:
        gs = fig.add_gridspec(2, 2, width_ratios=(1.15, 1.0), height_ratios=(1.6, 1.0))
    ax_b = fig.add_subplot(gs[:, 0])
    ax_m = fig.add_subplot(gs[0, 1])
    ax_p = fig.add_subplot(gs[1, 1], sharex=ax_m)
    opt, s0 = result.analysis, result.start_analysis
    draw_bands(ax_b, [(f"payload, start design ({s0.worst_margin_db:+.2f} dB)", start_all, START),
                      (f"payload, optimum ({opt.worst_margin_db:+.2f} dB)", optimum_all, OPTIMUM)],
               judged=judged)
    word = "PASS" if opt.passes else "FAIL"
    ax_b.set_title(f"optimum {word}: worst judged band {opt.worst_band_label} Hz, "
                   f"{opt.worst_margin_db:+.2f} dB (start {s0.worst_margin_db:+.2f} dB at "
                   f"{s0.worst_band_label} Hz)", fontsize=9.5, fontweight="bold",
                   color="C2" if opt.passes else "C3")
    for name, res, style in (("start", s0, START), ("optimum", opt, OPTIMUM)):
        valid = np.asarray(res.spring_diagnostics.valid).reshape(-1)
        fn = res.stability.natural_frequency_hz
        draw_transmissibility(ax_m, ax_p, res.grid.frequency_hz, res.transmissibility,
                              style=style, label=f"{name}: f_n {fn:.3g} Hz, stroke "
                              f"{res.equivalent_amplitude_m * 1e6:.3g} um",
                              valid=valid if valid.size == res.grid.frequency_hz.size else None,
                              flagged_label=name == "start")
    peak = st.constraints.get("max_peak_transmissibility_db")
    finish_transmissibility(ax_m, ax_p, opt.grid.frequency_hz,
                             peak if isinstance(peak, int | float) and peak is not True else None)
    ax_m.set_title("transmissibility at each design's operating amplitude", fontsize=9.5)
    p = st.payload
    # the fixed layout puts the title where the constrained layout would (3 points down)
    top = {} if fig.get_layout_engine() else {"y": 1.0 - 3.0 / 72.0 / fig.get_figheight()}
    fig.suptitle(f"study {st.name}: optimum {design_caption(result.design)} per isolator; "
                 f"payload {p.mass_kg:g} kg on {p.isolators} isolators; "
                 f"{floor_label(opt.floor_name)}; limit {opt.target_name}", fontsize=10,
                 **top)
    return fig


def optimization_plot(result, path: str | Path, *, dpi: int = 130) -> Path:
    """Write :func:`optimization_figure` to ``path`` with the Agg canvas; return the path.

    Parameters
    ----------
    result : OptimizationResult
    path : str or Path
    dpi : int

    Returns
    -------
    Path
    """
    return save_figure(optimization_figure(result), path, dpi=dpi)


def _design_label(d: dict) -> str:
    return (f"N {d['volume_ratio']:.3g}, V_t0 {d['top_volume_m3'] * 1e3:.3g} L\n"
            f"L_c {d['capillary_length_m'] * 1e3:.3g} mm, "
            f"D_c {d['capillary_diameter_m'] * 1e3:.3g} mm")


#: Relative change of N between neighbouring front points taken as a branch change.
BRANCH_JUMP = 0.3


def _branch_breaks(designs, order) -> np.ndarray:
    """True before a point whose N differs from its neighbour's by more than BRANCH_JUMP."""
    n = np.array([designs[i]["volume_ratio"] for i in order], float)
    br = np.zeros(n.size, bool)
    if n.size > 1:
        with np.errstate(divide="ignore", invalid="ignore"):
            br[1:] = np.abs(np.log(n[1:] / n[:-1])) > math.log1p(BRANCH_JUMP)
    return br


def _mark_envelope(ax, result, a: str, b: str, sa: float, sb: float) -> None:
    """The study's total-volume envelope (``constraints.max_total_volume_m3``) as a line."""
    env = (getattr(result, "settings", None) or {}).get("max_total_volume_m3")
    if not env or "total_volume" not in (a, b):
        return
    label = f"envelope: max_total_volume_m3 = {env * 1e3:g} L"
    if b == "total_volume":
        ax.axvline(env * sb, color="0.35", lw=1.0, ls=":", label=label)
    else:
        ax.axhline(env * sa, color="0.35", lw=1.0, ls=":", label=label)


def _explain_breaks(ax, result, order, xs, ys, breaks) -> list[str]:
    """Letter each break of the front's line and each change of its binding constraints.

    A break is a gap in the line (a point not solved, or a jump of N to another branch)
    or a kink where the set of binding constraints changes (``result.binding``, when the
    result carries it). Returns one line of text per letter.
    """
    binding = getattr(result, "binding", ()) or ()
    have_binding = len(binding) == len(result.designs)
    notes = []
    prev = None  # index (in order) of the last solved front point
    for k, i in enumerate(order):
        if not np.isfinite(ys[k]):
            continue
        if prev is not None:
            j = order[prev]
            why = []
            # sweep points (numbered in the order of the epsilon sweep) between the two
            # that were not solved: their objectives are unknown, so the line stops
            lo_i, hi_i = sorted((int(i), int(j)))
            skipped = [m for m in range(lo_i + 1, hi_i)
                       if not np.isfinite(np.asarray(result.values[m], float)).all()]
            if skipped:
                why.append("point " + ", ".join(f"#{m}" for m in skipped) + " not solved")
            n0, n1 = result.designs[j]["volume_ratio"], result.designs[i]["volume_ratio"]
            if breaks[k] and not skipped:
                why.append(f"branch change: N {n0:.3g} -> {n1:.3g}")
            if have_binding:
                b0, b1 = set(binding[j]), set(binding[i])
                if b0 != b1:
                    parts = [f"{c} binds" for c in sorted(b1 - b0)]
                    parts += [f"{c} released" for c in sorted(b0 - b1)]
                    why.append(", ".join(parts))
            if why:
                letter = chr(ord("a") + len(notes)) if len(notes) < 26 else "*"
                log = ax.get_xscale() == "log" and xs[prev] > 0 and xs[k] > 0
                xm = (xs[prev] * xs[k]) ** 0.5 if log else 0.5 * (xs[prev] + xs[k])
                ym = 0.5 * (ys[prev] + ys[k])
                ax.annotate(f"({letter})", (xm, ym), xytext=(-14, 4), textcoords="offset points",
                            fontsize=7, color="C3", ha="right")
                notes.append(f"({letter}) #{j} to #{i}: " + "; ".join(why))
        prev = k
    return notes


def pareto_figure(result, *, annotate: int = 5, ax=None):
    """The Pareto front of two objectives; the pass/fail line; a few designs listed.

    The swept objective (B) is on the x axis and the optimized one (A) on the y axis, in
    display units. Front points are joined in order of B, the line broken where a point
    failed (not solved) or where the design jumps to another branch (N changes by more
    than :data:`BRANCH_JUMP`): no design between them was computed. Each break, and each
    kink where the binding constraints change (``result.binding``), is lettered and
    explained in a box; the study's total-volume envelope (``settings``'
    ``max_total_volume_m3``) is drawn. Dominated points are grey, failed points are
    listed as crosses at the x axis. For the worst-band margin the pass/fail line
    (margin 0 dB) is drawn.

    Parameters
    ----------
    result : ParetoResult
        Or any object with ``objectives``, ``values``, ``designs``, ``front`` and
        ``hypervolume``.
    annotate : int
        Number of designs listed.
    ax : matplotlib Axes, optional

    Returns
    -------
    Figure
    """
    a, b = result.objectives
    sa, ua, na, max_a = objective_display(a)
    sb, ub, nb, max_b = objective_display(b)
    v = np.asarray(result.values, float)
    x, y = v[:, 1] * sb, v[:, 0] * sa
    ok = np.isfinite(x) & np.isfinite(y)
    front = np.asarray(result.front, bool) & ok
    dom = ok & ~front
    if ax is None:
        fig = new_figure(8.5, 6.0)
        ax = fig.add_subplot()
    else:
        fig = ax.figure
    # every point in sweep order along B; failed points break the line
    order = np.argsort(np.where(np.isfinite(x), x, np.inf), kind="stable")
    order = [i for i in order if front[i] or not ok[i]]
    xs = np.array([x[i] for i in order])
    ys = np.array([y[i] if front[i] else np.nan for i in order])
    breaks = _branch_breaks(result.designs, order) | ~np.isfinite(ys)
    lx, ly = with_breaks(xs, ys, breaks)
    ax.plot(lx, ly, color=OPTIMUM["color"], lw=1.6, label="non-dominated designs (computed)")
    _mark_envelope(ax, result, a, b, sa, sb)
    ax.plot(x[front], y[front], "o", color=OPTIMUM["color"], ms=5)
    if dom.any():
        ax.plot(x[dom], y[dom], "o", color="0.65", ms=5, label="dominated designs")
    failed = ~ok & np.isfinite(x)
    if failed.any():
        ax.plot(x[failed], np.full(int(failed.sum()), np.nanmin(y[ok]) if ok.any() else 0.0),
                "x", color="C3", ms=7, label="sweep point not solved")
    if "worst_band_margin" in (a, b):
        if a == "worst_band_margin":
            ax.axhline(0.0, **LIMIT, label="pass/fail: margin 0 dB (above: passes)")
        else:
            ax.axvline(0.0, **LIMIT, label="pass/fail: margin 0 dB (right: passes)")
    ok_x = x[ok]
    log_x = b in ("total_volume", "rms_velocity") and ok_x.size and ok_x.min() > 0 \
        and ok_x.max() / ok_x.min() > 5.0
    if log_x:
        from matplotlib.ticker import FixedLocator, FuncFormatter, NullFormatter

        ax.set_xscale("log")
        decades = np.arange(np.floor(np.log10(ok_x.min())), np.ceil(np.log10(ok_x.max())) + 1)
        ticks = [m * 10.0**e for e in decades for m in (1, 2, 5)
                 if ok_x.min() / 1.3 <= m * 10.0**e <= ok_x.max() * 1.3]
        if len(ticks) >= 2:
            ax.xaxis.set_major_locator(FixedLocator(ticks))
        ax.xaxis.set_major_formatter(FuncFormatter(lambda t, _pos: f"{t:g}"))
        ax.xaxis.set_minor_formatter(NullFormatter())
    ax.margins(x=0.08, y=0.1)
    notes = _explain_breaks(ax, result, order, xs, ys, breaks)
    idx = np.flatnonzero(front)
    idx = idx[np.argsort(x[idx])]
    n = idx.size
    if n and annotate > 0:
        # every front point numbered (its row in pareto.csv); the designs of a few, spread
        # along the front, listed in a box in the corner a front leaves empty (toward the
        # worse end of both objectives), so no label covers a point or the line
        picks = sorted({int(t + 0.5) for t in np.linspace(0, n - 1, min(annotate, n))})
        for i in idx:
            ax.annotate(str(i), (x[i], y[i]), xytext=(5, 5), textcoords="offset points",
                        fontsize=7, color="0.25")
        rows = [f"#{idx[k]}: {_design_label(result.designs[idx[k]]).replace(chr(10), ', ')}"
                for k in picks]
        down = max_a
        right = not max_b
        ax.text(0.985 if right else 0.015, 0.03 if down else 0.97,
                "designs (per isolator)\n" + "\n".join(rows), transform=ax.transAxes,
                ha="right" if right else "left", va="bottom" if down else "top", fontsize=7,
                family="monospace", multialignment="left",
                bbox={"boxstyle": "round,pad=0.4", "fc": "white", "ec": "0.75", "alpha": 0.95})
    if notes:  # in the corner the front leaves empty: the best of both objectives
        left, up = not max_b, max_a
        ax.text(0.015 if left else 0.985, 0.97 if up else 0.03,
                "breaks in the line\n" + "\n".join(notes), transform=ax.transAxes,
                ha="left" if left else "right", va="top" if up else "bottom", fontsize=7,
                multialignment="left",
                bbox={"boxstyle": "round,pad=0.4", "fc": "white", "ec": "0.75", "alpha": 0.95})
    better = {True: "higher is better", False: "lower is better"}
    ax.set_xlabel(f"{nb} ({ub}; {better[max_b]})")
    ax.set_ylabel(f"{na} ({ua}; {better[max_a]})")
    ax.set_title(f"Pareto front: {na} against {nb}\n{int(front.sum())} non-dominated of "
                 f"{len(v)} points; hypervolume {result.hypervolume:.3f} (normalized)",
                 fontsize=10)
    ax.grid(True, lw=0.4, alpha=0.6)
    # the notes' box holds the ideal corner; the legend goes to the middle of the other side
    loc = ("center right" if not max_b else "center left") if notes else "best"
    ax.legend(fontsize=8, loc=loc, framealpha=0.9)
    return fig


def pareto_plot(result, path: str | Path, *, annotate: int = 5, dpi: int = 130) -> Path:
    """Write :func:`pareto_figure` to ``path`` with the Agg canvas; return the path.

    Parameters
    ----------
    result : ParetoResult
    path : str or Path
    annotate : int
    dpi : int
    """
    return save_figure(pareto_figure(result, annotate=annotate), path, dpi=dpi)


def case_margin_bars(ax, cases, margins_db, *,
                     ylabel: str = "worst margin (dB, fine-grid analysis)") -> None:
    """The worst margin of each case of a design study as bars (red below 0 dB, green
    above), each labelled with its value, on ``ax``.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    cases : sequence of str
        The cases' names (underscores shown as spaces).
    margins_db : sequence of float
        Each case's worst margin, dB.
    ylabel : str, optional
        The y axis's label.
    """
    m = [float(v) for v in margins_db]
    x = range(len(m))
    ax.bar(x, m, color=["C3" if v < 0 else "C2" for v in m])
    for i, v in enumerate(m):
        ax.annotate(f"{v:+.2f}", (i, v), ha="center", va="bottom" if v >= 0 else "top",
                    fontsize=7)
    ax.axhline(0.0, color="k", lw=0.8)
    ax.set_xticks(list(x), [str(c).replace("_", " ") for c in cases], rotation=30,
                  ha="right", fontsize=7)
    ax.set_ylabel(ylabel)
