"""Figures of the table: band response per axis, transmissibility per axis, layout."""

from __future__ import annotations

import numpy as np

from isodesign.plotting.style import LIMIT, band_axis, candidate_style, new_figure

__all__ = ["table_bands_figure"]

_AXES = ("x", "y", "z")


def table_bands_figure(res, *, axes=None):
    """Band RMS velocity per axis at every instrument point, with floor and limit.

    Parameters
    ----------
    res : TableBandResponse
    axes : sequence of 3 matplotlib Axes, optional
        Default: a new figure with three panels.

    Returns
    -------
    matplotlib.figure.Figure
    """
    if axes is None:
        fig = new_figure(11.0, 3.6)
        axes = fig.subplots(1, 3, sharey=True)
    fig = axes[0].figure
    bands = res.bands
    x = np.arange(len(bands))
    for a, ax in enumerate(axes):
        ax.plot(x, res.floor_velocity_rms_m_s[a] * 1e6, color="0.55", lw=1.2, ls="--",
                label="floor")
        ax.plot(x, res.limit_velocity_rms_m_s * 1e6, color=LIMIT, lw=1.6,
                label=res.target_name)
        for p, name in enumerate(res.point_names):
            st = candidate_style(p)
            ax.plot(x, res.velocity_rms_m_s[p, a] * 1e6, marker="o", ms=3,
                    color=st.get("color"), lw=1.4, label=name)
        ax.set_yscale("log")
        band_axis(ax, bands)
        ax.set_title(f"{_AXES[a]} axis (worst {res.margin_db[:, a].min():+.1f} dB)", fontsize=10)
    axes[0].set_ylabel("band RMS velocity (um/s)")
    axes[0].legend(fontsize=7, loc="lower left")
    return fig
