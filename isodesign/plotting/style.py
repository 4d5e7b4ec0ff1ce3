"""One visual language for every isodesign figure: colours, line styles, axes, saving.

Every figure of the package (CLI, Python, HTML report) draws the same quantity the same
way: the floor is grey with dots, a limit (the target criterion, the peak-|T| limit) is a
black dashed line, the start design is red and dashed, the optimum (or the one design of
a figure) is blue and solid, candidates of a comparison take the colours of
:data:`CANDIDATE_COLOURS` in order. Points flagged outside a model's validity are orange
crosses; bands that fail the target are circled in red; the judged band range is shaded.

Figures are :class:`matplotlib.figure.Figure` objects with an Agg canvas, never made
through ``pyplot``: nothing here touches the global backend, so a notebook keeps its
own. Matplotlib is imported inside the functions (``import isodesign`` stays light).
"""

from __future__ import annotations

import io
import math
from pathlib import Path

import numpy as np

__all__ = [
    "CANDIDATE_COLOURS",
    "CANDIDATE_LINESTYLES",
    "FAIL",
    "FLAGGED",
    "FLAGGED_SPAN",
    "FLOOR",
    "JUDGED_SPAN",
    "LIMIT",
    "LINEAR",
    "OPTIMUM",
    "PEAK_LIMIT",
    "START",
    "UNITY",
    "band_axis",
    "candidate_style",
    "figure_svg",
    "frequency_axis",
    "new_figure",
    "save_figure",
    "with_breaks",
]

#: The floor's band RMS velocity.
FLOOR = {"color": "0.45", "ls": "-", "marker": "o", "ms": 3.5, "lw": 1.3}
#: A limit: the target criterion.
LIMIT = {"color": "black", "ls": (0, (6, 3)), "lw": 1.6}
#: The peak-|T| limit of a study (constraints.max_peak_transmissibility_db).
PEAK_LIMIT = {"color": "black", "ls": (0, (6, 2, 1, 2)), "lw": 1.2}
#: |T| = 1 (0 dB): the boundary between amplification and isolation.
UNITY = {"color": "0.55", "ls": "-", "lw": 0.9}
#: The start design of an optimization.
START = {"color": "C3", "ls": "--", "marker": "s", "ms": 3.5, "lw": 1.5}
#: The optimum, or the single design of a figure.
OPTIMUM = {"color": "C0", "ls": "-", "marker": "s", "ms": 3.5, "lw": 1.8}
#: The linear regime (spring at its 1 um reference amplitude): thin, drawn on top.
LINEAR = {"color": "black", "ls": (0, (2, 2)), "lw": 1.0, "zorder": 6}
#: Points outside a model's validity (sparse grids: crosses).
FLAGGED = {"color": "C1", "ls": "none", "marker": "x", "ms": 6, "mew": 1.6, "zorder": 7}
#: Stretches of a dense curve outside a model's validity: a wide orange band under the curve.
FLAGGED_SPAN = {"color": "C1", "ls": "-", "lw": 6.0, "alpha": 0.45, "zorder": 1,
                "solid_capstyle": "butt"}
#: Bands that exceed the target.
FAIL = {"ls": "none", "marker": "o", "mfc": "none", "mec": "C3", "ms": 11, "mew": 1.4,
        "zorder": 7}
#: The judged band range.
JUDGED_SPAN = {"color": "#dbe8f6", "alpha": 0.55, "lw": 0, "zorder": 0}
#: Colours of the candidates of a comparison, in order (the first is the optimum's blue).
CANDIDATE_COLOURS = ("C0", "C2", "C4", "C5", "C9", "C6", "C8", "C7")
#: Line styles of the candidates, in order (so that a grey-scale print still tells them apart).
CANDIDATE_LINESTYLES = ("-", "-.", (0, (1, 1.5)), (0, (8, 2)), (0, (3, 1, 1, 1, 1, 1)))
_CANDIDATE_MARKERS = ("s", "^", "D", "v", "P", "X", "*", "h")


def candidate_style(i: int) -> dict:
    """Line style of candidate ``i`` of a comparison (colour, line style, marker).

    Parameters
    ----------
    i : int
        The candidate's position in the comparison.
    """
    return {
        "color": CANDIDATE_COLOURS[i % len(CANDIDATE_COLOURS)],
        "ls": CANDIDATE_LINESTYLES[i % len(CANDIDATE_LINESTYLES)],
        "marker": _CANDIDATE_MARKERS[i % len(_CANDIDATE_MARKERS)],
        "ms": 4,
        "lw": 1.7,
    }


def new_figure(width_in: float, height_in: float, *, layout: str | None = "constrained"):
    """A :class:`~matplotlib.figure.Figure` with an Agg canvas (no pyplot, no backend switch).

    Parameters
    ----------
    width_in, height_in : float
        Size in inches.
    layout : str or None
        Matplotlib's layout engine: ``"constrained"`` (default) fits the axes around
        their labels when the figure is drawn; None leaves the axes where the caller put
        them (a figure with a fixed layout, drawn without the layout's measuring pass).

    Returns
    -------
    Figure
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width_in, height_in), layout=layout)
    FigureCanvasAgg(fig)
    return fig


def save_figure(fig, path, *, dpi: int = 130) -> Path:
    """Write ``fig`` to ``path`` (format from the suffix) with the Agg canvas; return the path.

    Parameters
    ----------
    fig : Figure
        Any Matplotlib figure; one from pyplot keeps its own canvas.
    path : str or Path
        Output file: PNG, PDF, SVG ...
    dpi : int
        Resolution of raster output.

    Returns
    -------
    Path
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    if not isinstance(fig.canvas, FigureCanvasAgg):
        # a figure from elsewhere (pyplot, a notebook): print it through Agg, leave it as it is
        own = fig.canvas
        try:
            FigureCanvasAgg(fig).print_figure(str(path), dpi=dpi)
        finally:
            fig.set_canvas(own)
        return Path(path)
    out = Path(path)
    fig.savefig(out, dpi=dpi)
    return out


def figure_svg(fig) -> str:
    """The figure as an inline ``<svg>`` element (no XML prolog, text kept as text).

    Parameters
    ----------
    fig : Figure

    Returns
    -------
    str
    """
    from matplotlib import rc_context

    buf = io.StringIO()
    with rc_context({"svg.fonttype": "none", "svg.hashsalt": "isodesign"}):
        fig.savefig(buf, format="svg")
    text = buf.getvalue()
    start = text.find("<svg")
    return text[start:].strip()


def with_breaks(x, y, breaks=None):
    """``(x, y)`` with NaN inserted where a line must not be drawn.

    A line is broken at every non-finite ``y`` (unsolved point) and before every
    index ``i`` where ``breaks[i]`` is True (a branch change between points ``i-1``
    and ``i``): Matplotlib draws no segment across a NaN, so no design that was never
    computed is implied.

    Parameters
    ----------
    x, y : array_like
        The points, in drawing order.
    breaks : array_like of bool, optional
        True at a point that starts a new segment.

    Returns
    -------
    (ndarray, ndarray)
        ``x`` and ``y`` with NaN separators.
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if breaks is None or not np.any(breaks):
        return x, np.where(np.isfinite(y), y, np.nan)
    xs, ys = [], []
    for i in range(x.size):
        if i and breaks[i]:
            xs.append(np.nan)
            ys.append(np.nan)
        xs.append(x[i])
        ys.append(y[i] if np.isfinite(y[i]) else np.nan)
    return np.asarray(xs), np.asarray(ys)


#: Octave-spaced band centres labelled on a band axis with many bands.
_OCTAVE_LABELS = (0.125, 0.25, 0.5, 1, 2, 4, 8, 16, 31.5, 63, 125, 250, 500, 1000)


def band_axis(ax, bands, *, judged=None, label: bool = True) -> None:
    """A log x axis of one-third-octave bands, labelled at band centres.

    Every band centre carries a tick; with more than 12 bands only the octave centres
    (1, 2, 4, 8, 16, 31.5, 63 Hz ...) are labelled, with their nominal names, so that
    labels never overlap. ``judged`` (a boolean mask over the bands) shades the judged
    range.

    Parameters
    ----------
    ax : matplotlib Axes
    bands : Bands
    judged : array_like of bool, optional
    label : bool
        Write the axis label.
    """
    from matplotlib.ticker import FixedFormatter, FixedLocator, NullFormatter

    c = np.asarray(bands.centre_hz, float)
    nominal = np.asarray(bands.nominal_hz, float)
    labels = list(bands.labels)
    ax.set_xscale("log")
    if len(c) <= 12:
        major = np.arange(len(c))
    else:
        major = np.flatnonzero([any(math.isclose(n, o, rel_tol=1e-6) for o in _OCTAVE_LABELS)
                                for n in nominal])
        if major.size < 2:
            major = np.arange(0, len(c), 3)
    ax.xaxis.set_major_locator(FixedLocator(c[major]))
    ax.xaxis.set_major_formatter(FixedFormatter([labels[i] for i in major]))
    ax.xaxis.set_minor_locator(FixedLocator(c))
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_xlim(c[0] / 1.15, c[-1] * 1.15)
    if judged is not None:
        judged = np.asarray(judged, bool)
        if judged.any() and not judged.all():
            lo = np.asarray(bands.lower_hz, float)[judged].min()
            hi = np.asarray(bands.upper_hz, float)[judged].max()
            ax.axvspan(lo, hi, **JUDGED_SPAN,
                       label=f"judged bands {labels[int(np.flatnonzero(judged)[0])]}-"
                             f"{labels[int(np.flatnonzero(judged)[-1])]} Hz")
    if label:
        ax.set_xlabel("one-third-octave band, nominal centre (Hz)")


def frequency_axis(ax, lo: float, hi: float, *, label: bool = True) -> None:
    """A log frequency axis with plain-number ticks (0.5, 1, 2, 4, 8, 16, 31.5, 63 ...).

    Parameters
    ----------
    ax : matplotlib Axes
    lo, hi : float
        Axis limits, Hz.
    label : bool
        Write the axis label.
    """
    from matplotlib.ticker import FixedLocator, FuncFormatter, NullFormatter

    ax.set_xscale("log")
    ticks = [t for t in (0.1, 0.2, 0.5, 1, 2, 4, 8, 16, 31.5, 63, 125, 250, 500, 1000)
             if lo * 0.97 <= t <= hi * 1.03]
    if len(ticks) >= 2:
        ax.xaxis.set_major_locator(FixedLocator(ticks))
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _pos: f"{v:g}"))
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_xlim(lo, hi)
    if label:
        ax.set_xlabel("frequency (Hz)")
