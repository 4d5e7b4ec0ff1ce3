"""Figures of isodesign, in one visual language (:mod:`isodesign.plotting.style`).

Every function returns a :class:`matplotlib.figure.Figure` made with an Agg canvas and
never touches Matplotlib's global backend; :func:`save_figure` writes one to a file and
:func:`figure_svg` gives it as inline SVG (the HTML report). The ``*_plot`` functions
write a figure to a path (the command line).

Names are resolved on first use, so that the result classes can import
:mod:`isodesign.plotting.response` without loading the optimizer's modules.
"""

from __future__ import annotations

from isodesign._lazy import lazy_exports

_EXPORTS = {
    "all_bands_response": "optimization",
    "objective_display": "optimization",
    "optimization_figure": "optimization",
    "optimization_plot": "optimization",
    "pareto_figure": "optimization",
    "pareto_plot": "optimization",
    "band_response_figure": "response",
    "bands_figure": "response",
    "design_caption": "response",
    "harmonic_figure": "response",
    "transmissibility_figure": "response",
    "plot_stiffness": "stiffness",
    "stiffness_figure": "stiffness",
    "figure_svg": "style",
    "new_figure": "style",
    "save_figure": "style",
}

__all__ = sorted(_EXPORTS)


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
