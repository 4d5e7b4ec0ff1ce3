"""Plots written to files (PNG, PDF, SVG) with Matplotlib's Agg canvas.

Matplotlib is imported inside the functions and used through
:class:`matplotlib.figure.Figure` with an Agg canvas, never through
``pyplot``: no GUI backend, no global state, safe in scripts and servers.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from isodesign.optimization.objectives import OBJECTIVES

__all__ = ["optimization_plot", "pareto_plot", "plot_stiffness"]

_LINESTYLES = ("-", "--", ":", "-.")


def _new_figure(width_in: float, height_in: float):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width_in, height_in), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def _curves(res):
    """(amplitude, frequency, k, loss factor) per amplitude, sorted by frequency."""
    import numpy as np

    f = np.asarray(res.frequency_hz, dtype=float).ravel()
    x = np.asarray(res.amplitude_m, dtype=float).ravel()
    k = np.asarray(res.k).ravel()
    eta = np.asarray(res.loss_factor, dtype=float).ravel()
    for amp in np.unique(x):
        sel = np.flatnonzero(x == amp)
        order = sel[np.argsort(f[sel], kind="stable")]
        yield float(amp), f[order], k[order], eta[order]


def plot_stiffness(
    path: str | Path,
    results: Sequence,
    *,
    labels: Sequence[str] | None = None,
    title: str | None = None,
    dpi: int = 150,
) -> Path:
    """Real part of k* and loss factor vs frequency, one curve per amplitude.

    Parameters
    ----------
    path : str or Path
        Output file; the format follows the suffix (``.png``, ``.pdf``, ``.svg``).
    results : sequence of StiffnessResult
        One or more results (for instance two models of the same spring). The
        same colour marks the same amplitude; each result gets its own line
        style (solid, dashed, dotted, dash-dot).
    labels : sequence of str, optional
        Legend label of each result (default: its flow model and amplitude mode).
    title : str, optional
        Figure title.
    dpi : int
        Resolution of raster output.

    Returns
    -------
    Path
        The written file.
    """
    results = list(results)
    if labels is None:
        labels = [f"{r.flow}, {r.amplitude_mode}" for r in results]
    fig = _new_figure(7.0, 6.5)
    ax_k, ax_eta = fig.subplots(2, 1, sharex=True)
    colours = {}
    palette = ("C0", "C1", "C2", "C3", "C4", "C5", "C6", "C7", "C8", "C9")
    for i, (res, label) in enumerate(zip(results, labels, strict=True)):
        ls = _LINESTYLES[i % len(_LINESTYLES)]
        for amp, f, k, eta in _curves(res):
            c = colours.setdefault(amp, palette[len(colours) % len(palette)])
            name = f"{amp * 1e3:.3g} mm"
            if len(results) > 1:
                name += f", {label}"
            ax_k.plot(f, k.real / 1e3, ls, color=c, marker=".", ms=3, label=name)
            ax_eta.plot(f, eta, ls, color=c, marker=".", ms=3, label=name)
    ax_k.set_xscale("log")
    from matplotlib.ticker import FuncFormatter

    ax_eta.xaxis.set_major_formatter(FuncFormatter(lambda v, _pos: f"{v:g}"))
    ax_k.set_ylabel("Re k* (kN/m)")
    ax_eta.set_ylabel("loss factor Im k* / Re k*")
    ax_eta.set_xlabel("frequency (Hz)")
    ax_eta.axhline(0.0, color="0.6", lw=0.6)
    for ax in (ax_k, ax_eta):
        ax.grid(True, which="both", lw=0.3, alpha=0.6)
    if len(results) > 1:
        # one column per result, below the axes: never hides a curve
        handles, names = ax_k.get_legend_handles_labels()
        fig.legend(handles, names, loc="outside lower center", ncol=len(results), fontsize="small")
    else:
        ax_k.legend(fontsize="small", loc="upper left")
    if title:
        fig.suptitle(title)
    out = Path(path)
    fig.savefig(out, dpi=dpi)
    return out


def _objective_display(kind: str) -> tuple[float, str, str]:
    """Display scale, unit and label of an objective (natural value x scale)."""
    o = OBJECTIVES.get(kind)
    return (o.display_scale, o.display_unit, o.label) if o else (1.0, "", kind)


def _maximized(kind: str) -> bool:
    return kind in OBJECTIVES and OBJECTIVES[kind].maximized


def _log_hz_axis(ax, lo: float, hi: float) -> None:
    """Plain-number frequency ticks (1, 2, 4, 8, 16, 31.5, 63, ...) on a log x axis."""
    from matplotlib.ticker import FixedLocator, FuncFormatter, NullFormatter

    ticks = [t for t in (0.1, 0.2, 0.5, 1, 2, 4, 8, 16, 31.5, 63, 125, 250)
             if lo * 0.97 <= t <= hi * 1.03]
    if len(ticks) >= 2:
        ax.xaxis.set_major_locator(FixedLocator(ticks))
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _pos: f"{v:g}"))
    ax.xaxis.set_minor_formatter(NullFormatter())


def optimization_plot(result, path: str | Path, *, dpi: int = 130) -> Path:
    """Band response and transmissibility of the start design and of the optimum.

    Left: one-third-octave band RMS velocity of the floor, of the payload on the
    start design and on the optimized design, and the target curve (log axes;
    the worst band of each design is circled). Right: ``|T|`` against frequency
    for both designs, each linearized at its own operating amplitude ``A*``.

    Parameters
    ----------
    result : OptimizationResult
        A feasible result of :func:`isodesign.optimization.driver.optimize` (with
        ``analysis`` and ``start_analysis``).
    path : str or Path
        Output file (``.png``, ``.pdf``, ``.svg``).
    dpi : int
        Resolution of raster output.

    Returns
    -------
    Path
        The written file.
    """
    import numpy as np

    opt, st = result.analysis, result.start_analysis
    if opt is None or st is None:
        raise ValueError("optimization_plot: the result has no band analysis (infeasible run)")
    fig = _new_figure(11.5, 4.6)
    ax1, ax2 = fig.subplots(1, 2)
    um = 1e6
    c = np.asarray(opt.bands.centre_hz, float)
    ax1.loglog(c, opt.floor_velocity_rms_m_s * um, "o-", color="0.45", ms=3,
               label=f"floor ({opt.floor_name})")
    ax1.loglog(c, st.payload_velocity_rms_m_s * um, "s--", color="C3", ms=3,
               label=f"payload, start ({st.worst_margin_db:+.2f} dB)")
    ax1.loglog(c, opt.payload_velocity_rms_m_s * um, "s-", color="C0", ms=3,
               label=f"payload, optimum ({opt.worst_margin_db:+.2f} dB)")
    ax1.loglog(c, opt.limit_velocity_rms_m_s * um, "k:", lw=1.5,
               label=f"target {opt.target_name}")
    for res, col in ((st, "C3"), (opt, "C0")):
        i = int(np.argmin(res.margin_db))
        ax1.plot(c[i], res.payload_velocity_rms_m_s[i] * um, "o", mfc="none", mec=col, ms=11)
    ax1.set_xlabel("one-third-octave band centre (Hz)")
    ax1.set_ylabel("band RMS velocity (um/s)")
    ax1.set_title(f"worst-band margin: start {st.worst_margin_db:+.2f} dB at "
                  f"{st.worst_band_label} Hz, optimum {opt.worst_margin_db:+.2f} dB at "
                  f"{opt.worst_band_label} Hz", fontsize=9)
    ax1.grid(True, which="both", lw=0.3, alpha=0.6)
    ax1.legend(fontsize=8)
    _log_hz_axis(ax1, float(c.min()), float(c.max()))
    for res, col, ls, name in ((st, "C3", "--", "start"), (opt, "C0", "-", "optimum")):
        s = res.stability
        ax2.loglog(res.grid.frequency_hz, np.abs(res.transmissibility), ls, color=col,
                   label=f"{name}: f_n {s.natural_frequency_hz:.3g} Hz, A* "
                   f"{res.equivalent_amplitude_m * 1e6:.3g} um")
    ax2.axhline(1.0, color="0.6", lw=0.8)
    ax2.set_xlabel("frequency (Hz)")
    ax2.set_ylabel("|T| (payload / floor) at A*")
    ax2.set_title("transmissibility at the operating amplitude", fontsize=9)
    ax2.grid(True, which="both", lw=0.3, alpha=0.6)
    ax2.legend(fontsize=8)
    f_all = np.asarray(opt.grid.frequency_hz, float)
    _log_hz_axis(ax2, float(f_all.min()), float(f_all.max()))
    v = result.values
    fig.suptitle(
        f"{result.study.name}: optimum N = {v['volume_ratio']:.3g}, V_t0 = "
        f"{v['top_volume_m3'] * 1e3:.3g} L, L_c = {v['capillary_length_m'] * 1e3:.3g} mm, "
        f"D_c = {v['capillary_diameter_m'] * 1e3:.3g} mm", fontsize=10)
    out = Path(path)
    fig.savefig(out, dpi=dpi)
    return out


def _design_label(d: dict) -> str:
    return (f"N {d['volume_ratio']:.3g}, V_t0 {d['top_volume_m3'] * 1e3:.3g} L\n"
            f"L_c {d['capillary_length_m'] * 1e3:.3g} mm, "
            f"D_c {d['capillary_diameter_m'] * 1e3:.3g} mm")


def pareto_plot(result, path: str | Path, *, annotate: int = 5, dpi: int = 130) -> Path:
    """The Pareto front of two objectives, with the designs of a few points annotated.

    The swept objective (B) is on the x axis and the optimized one (A) on the
    y axis, in display units (dB, L, um/s). Non-dominated points are joined;
    dominated points are grey; failed points (NaN) are left out. ``annotate``
    points spread along the front (both ends included) are labelled with N,
    V_t0 (L), L_c (mm) and D_c (mm). The hypervolume's reference point is
    marked.

    Parameters
    ----------
    result : ParetoResult
    path : str or Path
        Output file (``.png``, ``.pdf``, ``.svg``).
    annotate : int
        Number of labelled points.
    dpi : int
        Resolution of raster output.

    Returns
    -------
    Path
        The written file.
    """
    import numpy as np


    a, b = result.objectives
    sa, ua, na = _objective_display(a)
    sb, ub, nb = _objective_display(b)
    v = np.asarray(result.values, float)
    x, y = v[:, 1] * sb, v[:, 0] * sa
    ok = np.isfinite(x) & np.isfinite(y)
    front = np.asarray(result.front, bool) & ok
    dom = ok & ~front
    fig = _new_figure(8.5, 6.0)
    ax = fig.subplots()
    order = np.flatnonzero(front)[np.argsort(x[front])]
    ax.plot(x[order], y[order], "o-", color="C0", ms=5, label="non-dominated")
    if dom.any():
        ax.plot(x[dom], y[dom], "o", color="0.7", ms=5, label="dominated")
    # the hypervolume's reference point, back in natural units
    ref = np.asarray(result.reference_point, float)
    ref_nat = [(-r if _maximized(k) else r) for k, r in zip((a, b), ref, strict=True)]
    ax.plot(ref_nat[1] * sb, ref_nat[0] * sa, "kx", ms=8,
            label=f"hypervolume reference (HV = {result.hypervolume:.3f})")
    xs = x[ok]
    log_x = b in OBJECTIVES and not OBJECTIVES[b].db and xs.size and xs.min() > 0 \
        and xs.max() / xs.min() > 5.0
    if log_x:
        from matplotlib.ticker import FixedLocator, FuncFormatter, NullFormatter

        ax.set_xscale("log")
        decades = np.arange(np.floor(np.log10(xs.min())), np.ceil(np.log10(xs.max())) + 1)
        ticks = [m * 10.0**e for e in decades for m in (1, 2, 5)
                 if xs.min() / 1.3 <= m * 10.0**e <= xs.max() * 1.3]
        if len(ticks) >= 2:
            ax.xaxis.set_major_locator(FixedLocator(ticks))
        ax.xaxis.set_major_formatter(FuncFormatter(lambda t, _pos: f"{t:g}"))
        ax.xaxis.set_minor_formatter(NullFormatter())
    ax.margins(0.08)
    n = len(order)
    if n and annotate > 0:
        # labels go toward the reference point: the region a front dominates is empty
        picks = sorted({int(t + 0.5) for t in np.linspace(0, n - 1, min(annotate, n))})
        tx = np.log(x[order]) if log_x else x[order]
        span = max(float(tx.max() - tx.min()), 1e-300)
        ref_right = ref_nat[1] * sb > float(np.median(x[order]))
        ref_up = ref_nat[0] * sa > float(np.median(y[order]))
        for j, k in enumerate(picks):
            i = order[k]
            dy = 16 + 24 * (j % 2) if ref_up else -30 - 24 * (j % 2)
            pos = ((np.log(x[i]) if log_x else x[i]) - tx.min()) / span
            right = pos <= 0.85 if ref_right else pos < 0.15
            ax.annotate(_design_label(result.designs[i]), (x[i], y[i]),
                        xytext=(14 if right else -14, dy),
                        textcoords="offset points", fontsize=7,
                        ha="left" if right else "right", va="bottom" if ref_up else "top",
                        arrowprops={"arrowstyle": "-", "color": "0.5", "lw": 0.6},
                        bbox={"boxstyle": "round,pad=0.2", "fc": "white", "ec": "0.8",
                              "alpha": 0.9})
    sense = {True: "max", False: "min"}
    ax.set_xlabel(f"{nb} ({ub}, {sense[_maximized(b)]})")
    ax.set_ylabel(f"{na} ({ua}, {sense[_maximized(a)]})")
    ax.set_title(f"Pareto front: {a} vs {b} ({int(front.sum())} non-dominated of "
                 f"{len(v)} points)", fontsize=10)
    ax.grid(True, lw=0.3, alpha=0.6)
    ax.legend(fontsize=8, loc="best")
    out = Path(path)
    fig.savefig(out, dpi=dpi)
    return out
