"""Plots written to files (PNG, PDF, SVG) with Matplotlib's Agg canvas.

Matplotlib is imported inside the functions and used through
:class:`matplotlib.figure.Figure` with an Agg canvas, never through
``pyplot``: no GUI backend, no global state, safe in scripts and servers.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

__all__ = ["plot_stiffness"]

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
