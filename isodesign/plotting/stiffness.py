"""Figures of the spring's complex stiffness: real part and loss factor against frequency."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from isodesign.plotting.style import (
    CANDIDATE_COLOURS,
    CANDIDATE_LINESTYLES,
    FLAGGED,
    frequency_axis,
    new_figure,
    save_figure,
)

__all__ = ["plot_stiffness", "stiffness_figure"]

#: Amplitude colours (orange is kept for the validity flags).
_AMPLITUDE_COLOURS = ("C0", "C2", "C4", "C5", "C9", "C6", "C8", "C7")


def _curves(res):
    """(amplitude, frequency, k, loss factor, valid) per amplitude, sorted by frequency."""
    f = np.asarray(res.frequency_hz, dtype=float).ravel()
    x = np.asarray(res.amplitude_m, dtype=float).ravel()
    k = np.asarray(res.k).ravel()
    eta = np.asarray(res.loss_factor, dtype=float).ravel()
    valid = np.asarray(res.valid, bool).ravel()
    for amp in np.unique(x):
        sel = np.flatnonzero(x == amp)
        order = sel[np.argsort(f[sel], kind="stable")]
        yield float(amp), f[order], k[order], eta[order], valid[order]


def stiffness_figure(results, *, labels: Sequence[str] | None = None, title: str | None = None,
                     axes=None, colour_by: str = "amplitude", amplitudes_m=None):
    """Real part of k* (kN/m per isolator) and loss factor vs frequency, one curve per amplitude.

    Parameters
    ----------
    results : StiffnessResult or sequence of StiffnessResult
        One or more results (for instance two models of the same spring). The same colour
        marks the same amplitude; each result gets its own line style.
    labels : sequence of str, optional
        Legend label of each result (default: its flow model and amplitude mode).
    title : str, optional
    axes : pair of matplotlib Axes, optional
        Drawn into (real part, loss factor); default a new figure.
    colour_by : {'amplitude', 'result'}
        ``amplitude`` (default): one colour per amplitude, one line style per result;
        ``result``: one colour per result (the candidates' colours of a comparison), one
        line style per amplitude.
    amplitudes_m : sequence of float, optional
        Draw only these amplitudes (default all).

    Returns
    -------
    Figure
    """
    if not isinstance(results, Sequence):
        results = [results]
    results = list(results)
    if labels is None:
        labels = [f"{r.flow} flow, {r.amplitude_mode}" for r in results]
    stacked = axes is None
    if stacked:
        fig = new_figure(7.5, 6.5)
        ax_k, ax_eta = fig.subplots(2, 1, sharex=True)
    else:
        ax_k, ax_eta = axes
        fig = ax_k.figure
    colours: dict[float, str] = {}
    styles: dict[float, object] = {}
    flagged = False
    f_all = []
    keep = None if amplitudes_m is None else np.asarray(amplitudes_m, float)
    for i, (res, label) in enumerate(zip(results, labels, strict=True)):
        for amp, f, k, eta, valid in _curves(res):
            if keep is not None and not np.any(np.isclose(keep, amp, rtol=1e-9)):
                continue
            if colour_by == "result":
                c = CANDIDATE_COLOURS[i % len(CANDIDATE_COLOURS)]
                ls = styles.setdefault(amp, CANDIDATE_LINESTYLES[len(styles)
                                                              % len(CANDIDATE_LINESTYLES)])
            else:
                c = colours.setdefault(amp, _AMPLITUDE_COLOURS[len(colours)
                                                               % len(_AMPLITUDE_COLOURS)])
                ls = CANDIDATE_LINESTYLES[i % len(CANDIDATE_LINESTYLES)]
            name = f"stroke amplitude {amp * 1e3:.3g} mm"
            if len(results) > 1:
                name += f", {label}"
            ax_k.plot(f, k.real / 1e3, ls=ls, color=c, marker=".", ms=3, label=name)
            ax_eta.plot(f, eta, ls=ls, color=c, marker=".", ms=3, label=name)
            if (~valid).any():
                for ax, y in ((ax_k, k.real / 1e3), (ax_eta, eta)):
                    ax.plot(f[~valid], y[~valid], **FLAGGED,
                            label=None if flagged or ax is ax_eta else "outside model validity")
                flagged = True
            f_all.append(f)
    f_all = np.concatenate(f_all)
    frequency_axis(ax_k, float(f_all.min()) / 1.05, float(f_all.max()) * 1.05,
                   label=not stacked)
    frequency_axis(ax_eta, float(f_all.min()) / 1.05, float(f_all.max()) * 1.05)
    ax_k.set_ylabel("real part Re k* per isolator (kN/m)")
    ax_eta.set_ylabel("loss factor Im k* / Re k* (-)")
    ax_eta.axhline(0.0, color="0.6", lw=0.6)
    for ax in (ax_k, ax_eta):
        ax.grid(True, which="major", lw=0.4, alpha=0.6)
    handles, names = ax_k.get_legend_handles_labels()
    flag = [i for i, nm in enumerate(names) if nm == "outside model validity"]
    order = [i for i in range(len(names)) if i not in flag] + flag  # the flag entry last
    handles, names = [handles[i] for i in order], [names[i] for i in order]
    if len(results) > 1:
        ncol = len(results) if colour_by == "amplitude" else max(1, len(styles))
        fig.legend(handles, names, loc="outside lower center", ncol=ncol, fontsize="small")
    else:
        ax_k.legend(handles, names, fontsize="small", loc="upper left")
    if title:
        fig.suptitle(title, fontsize=10)
    return fig


def plot_stiffness(path: str | Path, results: Sequence, *, labels: Sequence[str] | None = None,
                   title: str | None = None, dpi: int = 150) -> Path:
    """Write :func:`stiffness_figure` to ``path`` (PNG, PDF, SVG) with the Agg canvas.

    Parameters
    ----------
    path : str or Path
    results : sequence of StiffnessResult
    labels : sequence of str, optional
    title : str, optional
    dpi : int

    Returns
    -------
    Path
        The written file.
    """
    return save_figure(stiffness_figure(results, labels=labels, title=title), path, dpi=dpi)
